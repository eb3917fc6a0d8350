"""Every command README.md and docs/*.md show runs, and the docs site builds with ``mkdocs build --strict``.

The fenced ```bash and ```python blocks are extracted and run in a temporary directory: ``track ...``
(also ``.venv/bin/track``) through [`track_apps.cli.main`][track_apps.cli.main], ``python examples/X.py ...``
(also ``.venv/bin/python``) through the example's ``main``, Python blocks as scripts. Long commands run
with a small budget through the allow-listed `SUBSTITUTIONS`; a command too expensive for the
default suite (full suites, training, ``make demo``) is in `SKIPPED` with the reason, and its
flags are checked against the command's ``--help``; a command another test runs is in
`COVERED`, naming that test.
"""

from __future__ import annotations

import contextlib
import html
import io
import os
import re
import runpy
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]

#: Allow-listed budget cuts: (regular expression, replacement), applied to every command and block.
SUBSTITUTIONS: list[tuple[str, str]] = [
    (r"--suite quick\b", "--envs SineTarget-v0 --agents pf --seeds 1 --steps 5"),  # 1 cell
    (r"--seeds \d+ --steps 300\b", "--seeds 1 --steps 5"),
    (r"--sweep noise_std=0,[0-9e,.-]*", "--sweep noise_std=0,2e-4"),
    (r"--steps (60|150|300)\b", "--steps 20"),
    (r"--png frame\.png", "--steps 10 --png frame.png"),
    (r"max_episode_steps=300", "max_episode_steps=5"),
    (r'render_mode="rgb_array"\)', 'render_mode="rgb_array", max_episode_steps=5)'),
    (r'base_env="BeltSorter-v0"\)', 'base_env="BeltSorter-v0", episode_steps=2)'),
    (r"n_frames=2000", "n_frames=20"),
]

#: Commands not run here (matched at the start of the command): the reason. Their flags are checked.
SKIPPED: dict[str, str] = {
    "make demo": "a venv and the quick suite (minutes); its cells run in tests/track_apps/bench",
    "make test": "the whole test suite, this test included",
    "make bench-check": "timings (minutes, noisy): not part of the test suite",
    "source .venv/bin/activate": "shell set-up; the commands below run with the venv's python",
    "track bench run --suite full": "the full suite (hours)",
    "track bench run --suite sorting": "the sorting suite (an hour)",
    "track bench run --suite pollithy2020": "the paper suite (an hour; --quick: minutes)",
    "track bench run --suite okada2020": "the paper suite (an hour; --quick: tens of minutes)",
    "track bench run --suite results/": "a suite a previous command writes (a grid of hundreds of cells)",
    "track bench claims": "needs the records of the full pollithy2020 suite",
    "track train": "training a model (minutes to hours, torch)",
    "track tune train": "PPO training (20 min)",
    "track tune grid-suite": "writes a grid suite that the next commands run (hours)",
    "track tune best-fixed": "needs the records of the grid suite",
    "track tune evaluate --seeds": "paired evaluations over 10-20 held-out seeds (tens of minutes)",
    "track tune sensor-grid": "a grid over sensor states (tens of minutes)",
    "track run sorter.csv": "a sorter recording of your own (the shipped sample runs in the next block)",
    "track run det.txt": (
        "illustrative name; the TUD-Campus recipe runs in tests/track_apps/cli/test_run_boxes.py"
    ),
    "python examples/pf_paper_figures.py --runs 100": "14 min; its --quick run is in tests/test_examples.py",
    "python examples/gate_tuning_trace.py --table results/": "needs the sensor table of the grid above",
    "python benchmarks/okada2020_table.py": "needs the records of the okada2020 suite",
    "for m in": "recalibrating the shipped models (minutes, torch)",
    'COMMON="': "a variable of the training commands below",
}

#: Commands another test runs (the command as the page writes it, after joining lines): that test.
COVERED: dict[str, str] = {
    "track run recording.csv --dt 0.005 --out tracks.csv": "tests/agents/test_sensor_model.py",
    "track run track_envs/data/detections_sample.zip --time-column time --declared-noise-std 1e-4 "
    "--out tracks.csv --sorting-check line=0.35,cut=0.3": "tests/agents/test_sorting_check.py",
    "DATA=$(python -c": "tests/track_apps/cli/test_run_boxes.py",
    "track run $DATA/test.txt": "tests/track_apps/cli/test_run_boxes.py",
    "python examples/score_with_motmetrics.py $DATA/gt.txt": "tests/test_examples.py",
    "track run det.json --agent pose-baseline --gt gt.json --metrics --out tracks.json": (
        "tests/track_apps/cli/test_run_pose.py"
    ),
    "track run video.json --agent pose-smc": "tests/track_apps/cli/test_run_pose.py (slow)",
}

#: Synopsis lines (``track bench run|list|...``) and the like: not commands.
SYNOPSIS = re.compile(r"\||\.\.\.|\bCOMMAND\b|\bKIND\b|\bDETECTIONS\b")

#: Python blocks not run (matched by a line they contain): the reason. They are compiled.
PYTHON_SKIPPED: dict[str, str] = {
    'weights="models/my-material"': "loads a model file of your own",
    'model_weights="models/displacement-lstm-pw"': "loads a model file of your own",
    'device="cuda"': "needs a GPU (tests/agents/test_pose_smc_device.py runs it where there is one)",
    "estimate_sensor_model(detections, spec": "a fragment on a detection stream of the page's text",
}

#: Names every Python block may use without importing them (the pages' fragments assume them).
PREAMBLE = "import gymnasium as gym\nimport track_envs\nfrom agents import make_agent\n"


@dataclass(frozen=True)
class Block:
    page: Path
    line: int
    lang: str
    text: str

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks() -> list[Block]:
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"^```(bash|python)\n(.*?)^```", text, re.M | re.S):
            found.append(Block(page, text[: m.start()].count("\n") + 1, m.group(1), m.group(2)))
    return found


def commands(text: str) -> list[str]:
    """The block's commands, continuation lines joined and comments dropped; a ``for`` loop is one."""
    joined = text.replace("\\\n", " ")
    out: list[str] = []
    loop: list[str] = []
    for raw in joined.splitlines():
        line = raw.strip()
        if loop or line.startswith("for "):
            loop.append(line)
            if line == "done":
                out.append("; ".join(loop))
                loop = []
            continue
        line = re.sub(r"\s+#.*$", "", line) if not line.startswith("#") else ""
        if line:
            out.append(re.sub(r"\s+", " ", line))
    return out


def substitute(text: str) -> str:
    for pattern, replacement in SUBSTITUTIONS:
        text = re.sub(pattern, replacement, text)
    return text


def lookup(table: dict[str, str], command: str) -> str | None:
    return next((v for k, v in table.items() if command.startswith(k)), None)


def normalise(command: str) -> str:
    return re.sub(r"^\.venv/bin/", "", command)


def help_text(argv: list[str]) -> str:
    """The ``--help`` of a ``track`` subcommand or an example script."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        run_argv([*argv, "--help"])
    return out.getvalue()


def run_argv(argv: list[str]) -> None:
    if argv[0] == "track":
        from track_apps.cli import main

        try:
            assert main(argv[1:]) == 0, argv
        except SystemExit as exc:  # --help
            assert exc.code in (0, None), argv
    elif argv[0] == "python" and argv[1].startswith(("examples/", "benchmarks/")):
        old = sys.argv
        sys.argv = [str(ROOT / argv[1]), *argv[2:]]
        try:
            runpy.run_path(str(ROOT / argv[1]), run_name="__main__")
        except SystemExit as exc:
            assert exc.code in (0, None), argv
        finally:
            sys.argv = old
    else:
        raise AssertionError(f"no runner for {argv}")


def check_flags(command: str) -> None:
    """A skipped command's flags are options its ``--help`` lists."""
    if command.startswith("make "):
        target = command.split()[1]
        assert re.search(rf"^{target}:", (ROOT / "Makefile").read_text(), re.M), target
        return
    argv = shlex.split(command)
    if argv[0] not in ("track", "python") or "$" in command or ";" in command:
        return
    depth = 3 if argv[0] == "track" and argv[1] in ("bench", "tune", "train") else 2
    text = help_text(argv[:depth])
    for flag in {a.split("=", 1)[0] for a in argv if a.startswith("--")}:
        assert flag in text, f"{command}: {flag} is not in the help of {' '.join(argv[:depth])}"


BASH = [b for b in blocks() if b.lang == "bash"]
PYTHON = [b for b in blocks() if b.lang == "python"]


@pytest.fixture
def workdir(tmp_path, monkeypatch, scoped_registries):
    """The block's working folder; what a block registers stays out of the other tests' registries."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    return tmp_path


@pytest.mark.parametrize("block", BASH, ids=lambda b: b.id)
def test_bash_block_runs(block, workdir, capsys):
    for command in commands(block.text):
        command = normalise(command)
        if SYNOPSIS.search(command) and command.split()[0] == "track":
            run_argv(["track", "list"]) if command.startswith("track list") else None
            continue
        if lookup(COVERED, command) is not None:
            continue
        if (reason := lookup(SKIPPED, command)) is not None:
            assert reason
            check_flags(command)
            continue
        argv = shlex.split(substitute(command))
        if argv[:3] == ["track", "bench", "run"]:
            argv += ["--workers", "1", "--no-progress"]
        elif argv[:2] == ["track", "run"]:
            argv += ["--no-progress"]
        run_argv(argv)


@pytest.mark.parametrize("block", PYTHON, ids=lambda b: b.id)
def test_python_block_runs(block, workdir, capsys):
    compile(PREAMBLE + block.text, block.id, "exec")  # every block is valid Python
    if any(key in block.text for key in PYTHON_SKIPPED):
        return
    exec(compile(PREAMBLE + substitute(block.text), block.id, "exec"), {"__name__": "__main__"})


def test_every_skip_and_cover_entry_is_used():
    """The tables name only commands the pages show (a stale entry hides nothing)."""
    shown = [normalise(c) for b in BASH for c in commands(b.text)]
    for table in (SKIPPED, COVERED):
        for key in table:
            assert any(c.startswith(key) for c in shown), key
    for key in PYTHON_SKIPPED:
        assert any(key in b.text for b in PYTHON), key


def test_readme_fits_on_a_screen_and_keeps_its_commands():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    for phrase in ("make demo", "make test", "source .venv/bin/activate", ".venv/bin/track", "## References"):
        assert phrase in text
    for link in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / link).exists(), link


def test_pages_import_only_public_package_names():
    """The docs' Python imports from the packages' top level, their public subpackages and modules
    (no ``_private`` module)."""
    for block in PYTHON:
        for module in re.findall(r"^\s*(?:from|import) ([\w.]+)", block.text, re.M):
            assert not any(part.startswith("_") for part in module.split(".")), (block.id, module)


@pytest.mark.skipif(
    shutil.which("mkdocs") is None and not (Path(sys.executable).parent / "mkdocs").exists(),
    reason="mkdocs is not installed (the dev extra)",
)
def test_mkdocs_build_strict(tmp_path):
    mkdocs = Path(sys.executable).parent / "mkdocs"
    exe = [str(mkdocs)] if mkdocs.exists() else ["mkdocs"]
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    result = subprocess.run(
        [*exe, "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    site = tmp_path / "site"
    assert (site / "api" / "agents.html").exists()
    assert_links_resolve_on_disk(site)


def assert_links_resolve_on_disk(site: Path) -> None:
    """Every relative link and asset of the built pages names a file of the site (no directory URL)
    and, with a fragment, an id of that page: the site browses from ``file://``. The 404 page is
    served by a web server only and uses absolute URLs."""
    ids: dict[Path, set[str]] = {}
    bad = []
    for page in sorted(site.rglob("*.html")):
        if page.name == "404.html":
            continue
        for ref in re.findall(r'(?:href|src)="([^"]+)"', page.read_text(encoding="utf-8")):
            ref = html.unescape(ref)
            if re.match(r"^[a-z][a-z0-9+.-]*:", ref):  # https:, mailto:, data:
                continue
            path, _, fragment = ref.partition("#")
            target = (page.parent / path).resolve() if path else page.resolve()
            if not target.is_file():
                bad.append(f"{page.relative_to(site)}: {ref}")
            elif fragment and target.suffix == ".html":
                if target not in ids:
                    ids[target] = set(re.findall(r'id="([^"]+)"', target.read_text(encoding="utf-8")))
                if fragment not in ids[target]:
                    bad.append(f"{page.relative_to(site)}: {ref} (no such anchor)")
    assert not bad, bad[:20]
