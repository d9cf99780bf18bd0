"""A change of results comes with a revision bump (solver/revision.py), and the compiled kernels
follow the source they came from (solver/compile/kernel_cache.py)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import results_fingerprint as fp
from solver.compile import kernel_cache
from solver.revision import RESULTS_REVISION

ROOT = Path(__file__).resolve().parents[1]


def test_results_are_the_fingerprinted_ones_or_the_revision_was_bumped():
    """On a machine whose fingerprint is recorded, every case's results are bit for bit those
    recorded at today's revisions. A difference at an unchanged revision is a results change that
    forgot its bump; a bumped revision wants its new fingerprint recorded (make fingerprint)."""
    entry = fp.load().get(fp.machine_key(fp.machine()))
    if entry is None:
        pytest.skip(f"no fingerprint recorded on this machine ({fp.machine()}): make fingerprint")
    now = fp.fingerprint()
    changed = sorted(name for name, (rule, digest) in now.items() if entry["fingerprint"].get(name) != [rule, digest])
    bumped = sorted(r for r in RESULTS_REVISION if RESULTS_REVISION[r] != entry["revisions"].get(r))
    forgot = sorted({now[name][0] for name in changed if not set(now[name][0].split("+")) & set(bumped)})
    assert not forgot, (f"results changed under {forgot} at an unchanged revision ({', '.join(changed)}): "
                        "bump RESULTS_REVISION in solver/revision.py, then make fingerprint")
    assert not bumped, f"the revision of {bumped} was bumped: record its fingerprint (make fingerprint)"


def test_the_fingerprint_sees_a_change_of_one_bit(monkeypatch):
    """The digest moves with the last bit of any output (so a change cannot hide in it)."""
    from solver import Parameters, Settings, solve
    r = solve(Parameters(Nmod=4), Settings(fixed_step=0.05, error_estimate=False), fields=("strain",))
    before = fp._digest(r)
    i = np.flatnonzero(np.isfinite(r.force))[-1]
    r.force[i] = np.nextafter(r.force[i], np.inf)
    assert fp._digest(r) != before


def _run(package_root: Path, code: str, env_extra=None) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("FLOE_IMPACT_KERNEL_CACHE", "NUMBA_CACHE_DIR")}
    env.update(PYTHONPATH=str(package_root), **(env_extra or {}))
    proc = subprocess.run([sys.executable, "-c", code], cwd=package_root, env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


#: a small kernel of solver/model/layer.py that carries solver/model/law.py compiled inside it
PROBE = """
import numpy as np, solver
from solver import Parameters
from solver.model.assemble import Tables
from solver.model.layer import node_energy
m = Tables(Parameters(Nmod=2), 16, False, "paper", 4).model
delta = np.linspace(0.5, -0.5, m.basis.cosq.shape[1])
e = node_energy(m, delta, delta.size)
print(repr(e), sum(node_energy.stats.cache_hits.values()), solver._kernel_cache.SolverCacheLocator.directory)
"""


def test_an_edit_of_a_model_module_changes_the_next_run(tmp_path):
    """The issue's trial in a copy of the package: a kernel compiled and cached, then the layer's
    law edited in its own file: the next run computes with the edited law, no manual step; an
    unedited tree loads from the cache."""
    shutil.copytree(ROOT / "solver", tmp_path / "solver", ignore=shutil.ignore_patterns("__pycache__"))
    first = _run(tmp_path, PROBE).split()
    again = _run(tmp_path, PROBE).split()
    assert again[0] == first[0] and again[1] == "1" and again[2] == first[2], (first, again)
    law = tmp_path / "solver" / "model" / "law.py"
    text = law.read_text()
    assert "return -d - math.log1p(-d)" in text
    law.write_text(text.replace("return -d - math.log1p(-d)", "return 2.0 * (-d - math.log1p(-d))"))
    edited = _run(tmp_path, PROBE).split()
    assert edited[1] == "0" and edited[2] != first[2]
    assert float(edited[0]) == pytest.approx(2.0 * float(first[0]), rel=1e-14)


def test_the_cache_key_follows_every_source_file_and_the_target(tmp_path):
    """Any file of the package, added or edited, moves the key; a copy elsewhere with the same
    source (a wheel's site-packages, a worker) has the same key; another numba target has
    another."""
    copy = tmp_path / "site-packages" / "solver"
    shutil.copytree(ROOT / "solver", copy, ignore=shutil.ignore_patterns("__pycache__"))
    key = kernel_cache.cache_key(copy)
    assert key == kernel_cache.cache_key()
    (copy / "observe" / "events.py").write_text((copy / "observe" / "events.py").read_text() + "\n# note\n")
    edited = kernel_cache.cache_key(copy)
    assert edited != key
    (copy / "observe" / "new_piece.py").write_text("X = 1\n")
    assert kernel_cache.cache_key(copy) not in (key, edited)
    # (its own cache root: importing solver makes the key's directory and prunes the root)
    generic = _run(ROOT, "from solver.compile import kernel_cache; print(kernel_cache.cache_key())",
                   {"NUMBA_CPU_NAME": "generic", "FLOE_IMPACT_KERNEL_CACHE": str(tmp_path / "cache")})
    assert generic.startswith("generic-") and generic != key


def test_old_keys_are_pruned_to_the_most_recently_used(tmp_path, monkeypatch):
    monkeypatch.setenv("FLOE_IMPACT_KERNEL_CACHE", str(tmp_path))
    for i in range(kernel_cache.KEEP + 3):
        d = tmp_path / f"old-{i}"
        d.mkdir()
        os.utime(d, (1000.0 + i, 1000.0 + i))
    made = kernel_cache.open_directory()
    kept = sorted(p.name for p in tmp_path.iterdir())
    assert made.name in kept and len(kept) == kernel_cache.KEEP
    assert "old-0" not in kept and f"old-{kernel_cache.KEEP + 2}" in kept


def test_a_dask_worker_compiles_into_the_same_directory():
    """Workers are processes of their own: they import the same source, so the same key and
    directory (the runner fills it, the workers load it)."""
    from pipeline.compute.engine import cluster_client
    with cluster_client(1, None) as client:
        seen = client.run(lambda: str(__import__("solver")._kernel_cache.SolverCacheLocator.directory))
    assert set(seen.values()) == {str(kernel_cache.SolverCacheLocator.directory)}


def test_the_cache_is_complete_only_with_every_index_compile_kernels_listed(tmp_path, monkeypatch):
    """compile_kernels lists the index files it left; a run skips its compile process only while
    every one of them is there (deleting one, as after `find solver -name "*.nb[ic]" -delete`,
    makes the next run fill the cache again)."""
    monkeypatch.setattr(kernel_cache.SolverCacheLocator, "directory", tmp_path)
    assert not kernel_cache.is_complete()                                # nothing written yet
    (tmp_path / "model").mkdir()
    for name in ("loop.integrate-1.py311.nbi", "model/basis.peak-2.py311.nbi"):
        (tmp_path / name).write_text("index")
    kernel_cache.mark_complete()
    assert (tmp_path / kernel_cache.COMPLETE).read_text().split() == ["loop.integrate-1.py311.nbi",
                                                                       "model/basis.peak-2.py311.nbi"]
    assert kernel_cache.is_complete()
    (tmp_path / "model" / "basis.peak-2.py311.nbi").unlink()
    assert not kernel_cache.is_complete()


def test_a_run_starts_no_compile_process_when_the_cache_is_complete(monkeypatch, capsys):
    from pipeline.compute import engine
    monkeypatch.setattr(kernel_cache, "is_complete", lambda: True)
    monkeypatch.setattr(engine.subprocess, "Popen", lambda *a, **k: pytest.fail("a compile process started"))
    handle = engine.start_kernels()
    engine.kernels_ready(handle)
    assert handle[0] is None and "kernels ready (cached)" in capsys.readouterr().err
