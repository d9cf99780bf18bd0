"""What the benchmarks share: a report written to results/bench/<name>.md and printed."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def write_report(name: str, lines) -> Path:
    """Write the report's lines to results/bench/<name>.md (outside git), print them, and return
    the path."""
    text = "\n".join(lines) + "\n"
    out = ROOT / "results" / "bench" / f"{name}.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)
    return out
