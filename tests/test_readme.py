"""Every snippet of the README runs (issue 22): its Python block as written (a study of 8 cases,
in a scratch directory), its study file through the study checks, and each command line of its
shell blocks (a run as --dry-run, status, show into a scratch figure)."""
import re
import shlex
import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def blocks(language: str) -> list:
    return re.findall(rf"```{language}\n(.*?)```", README, re.S)


def test_the_readme_is_one_page_and_has_its_snippets():
    assert README.count("\n") <= 250
    assert len(blocks("python")) == 1 and len(blocks("toml")) == 1 and len(blocks("sh")) == 2


def test_the_python_snippet_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "readme"}
    exec(compile(blocks("python")[0], "README.md", "exec"), namespace)
    ds, case = namespace["ds"], namespace["case"]
    assert namespace["r"].status == "ok" and case["strain"].dims == ("t", "x")
    assert ds["max_strain"].dims == ("V", "hi") and (tmp_path / "results" / "my_sweep" / "study.nc").is_file()


def test_the_study_file_snippet_is_a_valid_study():
    from pipeline.study.definition import load_study_text
    study = load_study_text(blocks("toml")[0], "readme")
    assert study.dims == ["V", "hi"] and study.n_cases == 24


def _commands() -> list:
    lines = [line.split("#")[0].strip() for block in blocks("sh") for line in block.splitlines()]
    return [shlex.split(line) for line in lines if line]


def test_every_command_line_of_the_readme_runs(tmp_path):
    commands = _commands()
    assert [c[:2] for c in commands] == [["make", "study"], ["make", "test"], ["floe-impact", "run"],
                                         ["floe-impact", "status"], ["floe-impact", "show"]]
    script = Path(sys.executable).with_name("floe-impact")
    for command in commands[2:]:                 # make study and make test: CI runs them
        args = [str(script), *command[1:]]
        if command[1] == "run":
            args.append("--dry-run")             # what it would run, not the 24 cases
        if command[1] == "show":
            args += ["--figure", str(tmp_path / "case.png")]
        proc = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, (command, proc.stderr)
    assert (tmp_path / "case.png").is_file()
