"""Every runnable block of README.md and docs/*.md runs, and a shell session prints what
the page says it prints; the relative links of those pages and of renders/README.md and
examples/README.md resolve.

A fence whose info string is ``python run`` is run as a script; ``console run`` is a
shell session: each ``$ `` line is a command (a trailing ``\\`` continues it), the lines
after it its expected output (stdout and stderr as a terminal shows them). An expected
line that is just ``...`` stands for any number of lines, and ``...`` inside a line for
any text. Every command must exit with status 0 (a page that shows a failing command
writes ``cmd || echo "exit status $?"``). A ``slow`` word in the info string marks the
block ``@pytest.mark.slow``.

Blocks run in a scratch folder that mirrors the repository's top level through links
(so ``scenes/circle.toml`` or ``examples/...`` resolve as from the repository root),
without its ``renders/``: whatever a block writes lands in the scratch folder, never in
the checkout. ``humanoid-ik`` and ``python`` are this interpreter's (a small shim folder
first on ``PATH``), ``MUJOCO_GL=egl``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import matplotlib.image
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "renders" / "README.md",
    ROOT / "examples" / "README.md",
]
RUNNABLE = ("python", "console")
MIRROR_SKIP = {"renders", ".git", ".venv", ".pytest_cache", ".ruff_cache", ".mypy_cache"}
TIMEOUT_S = 300
README_MAX_LINES = 210  # "at most about 200": the front page, everything else in docs/

_FENCE = re.compile(r"^(`{3,}|~{3,})(.*)$")
_LINK = re.compile(r"\]\(([^)\s]+)\)")


@dataclass(frozen=True)
class Block:
    """One fenced code block of a page."""

    page: Path
    line: int
    """1-based line of the opening fence."""
    info: tuple[str, ...]
    """The info string's words: language first, then flags such as ``run``, ``slow``."""
    text: str

    @property
    def lang(self) -> str:
        return self.info[0] if self.info else ""

    @property
    def runnable(self) -> bool:
        return self.lang in RUNNABLE and "run" in self.info[1:]

    @property
    def name(self) -> str:
        page = self.page.relative_to(ROOT) if self.page.is_relative_to(ROOT) else self.page
        return f"{page}:{self.line}"


def parse_blocks(page: Path) -> list[Block]:
    """The fenced code blocks of a markdown page, in order."""
    blocks: list[Block] = []
    lines = page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info = m.group(1), tuple(m.group(2).split())
        start, body = i + 1, []
        i += 1
        while i < len(lines) and not (
            lines[i].startswith(fence[0] * len(fence)) and not lines[i].strip(fence[0]).strip()
        ):
            body.append(lines[i])
            i += 1
        blocks.append(Block(page, start, info, "\n".join(body) + "\n"))
        i += 1
    return blocks


def all_blocks() -> list[Block]:
    return [b for page in PAGES for b in parse_blocks(page)]


def runnable_params(lang: str) -> list:
    return [
        pytest.param(b, id=b.name, marks=[pytest.mark.slow] if "slow" in b.info else [])
        for b in all_blocks()
        if b.runnable and b.lang == lang
    ]


# --- the console session format ------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """One ``$ `` command of a console block and the output the page shows for it."""

    line: int
    command: str
    expected: list[str]


def parse_session(block: Block) -> list[Command]:
    """Split a console block into commands and their expected output."""
    commands: list[Command] = []
    lines = block.text.splitlines()
    i = 0
    while i < len(lines):
        if not lines[i].startswith("$ "):
            if lines[i].strip():
                raise AssertionError(f"{block.name}: output before the first '$ ' command")
            i += 1
            continue
        line = block.line + 1 + i
        parts = [lines[i][2:]]
        while parts[-1].endswith("\\") and i + 1 < len(lines):
            parts[-1] = parts[-1][:-1]
            i += 1
            parts.append(lines[i])
        i += 1
        expected: list[str] = []
        while i < len(lines) and not lines[i].startswith("$ "):
            expected.append(lines[i].rstrip())
            i += 1
        while expected and not expected[-1]:
            expected.pop()
        commands.append(Command(line, " ".join(p.strip() for p in parts), expected))
    return commands


def _line_pattern(expected: str) -> re.Pattern[str]:
    return re.compile(".*".join(re.escape(part) for part in expected.split("...")))


def output_matches(expected: list[str], actual: list[str]) -> bool:
    """Whether ``actual`` lines fit ``expected``: a ``...`` line matches any number of
    lines, ``...`` in a line any text, everything else exactly (trailing spaces aside)."""
    pats = [None if e.strip() == "..." else _line_pattern(e.rstrip()) for e in expected]
    act = [a.rstrip() for a in actual]
    while act and not act[-1]:
        act.pop()
    # reach[j]: the expected lines so far can consume exactly the first j actual lines
    reach = [True] + [False] * len(act)
    for pat in pats:
        nxt = [False] * (len(act) + 1)
        for j, ok in enumerate(reach):
            if not ok:
                continue
            if pat is None:
                for k in range(j, len(act) + 1):
                    nxt[k] = True
                break
            if j < len(act) and pat.fullmatch(act[j]):
                nxt[j + 1] = True
        reach = nxt
    return reach[len(act)]


# --- where blocks run ----------------------------------------------------------------


@pytest.fixture
def workspace(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """A scratch folder that looks like the repository root, and the environment."""
    work = tmp_path / "repo"
    work.mkdir()
    for entry in ROOT.iterdir():
        if entry.name not in MIRROR_SKIP and not entry.name.startswith(".venv"):
            (work / entry.name).symlink_to(entry, target_is_directory=entry.is_dir())
    shims = tmp_path / "bin"
    shims.mkdir()
    exe = sys.executable
    for name, args in (("python", ""), ("python3", ""), ("humanoid-ik", " -m humanoid_ik")):
        shim = shims / name
        shim.write_text(f'#!/bin/sh\nexec "{exe}"{args} "$@"\n')
        shim.chmod(0o755)
    env = dict(os.environ)
    env.update(
        PATH=f"{shims}{os.pathsep}{env.get('PATH', '')}",
        MUJOCO_GL="egl",
        COLUMNS="100",
        PYTHONHASHSEED="0",
        MPLBACKEND="Agg",
    )
    return work, env


# --- the tests -------------------------------------------------------------------------


@pytest.mark.parametrize("block", runnable_params("python"))
def test_python_block_runs(block: Block, workspace: tuple[Path, dict[str, str]]) -> None:
    """A ``python run`` block runs to the end without an error (its asserts hold)."""
    work, env = workspace
    script = work / "doc_block.py"
    script.write_text(block.text, encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, str(script)],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    assert proc.returncode == 0, (
        f"{block.name}: python block exited {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
    )


@pytest.mark.parametrize("block", runnable_params("console"))
def test_console_block_output(block: Block, workspace: tuple[Path, dict[str, str]]) -> None:
    """Each command of a ``console run`` block exits 0 and prints the output shown."""
    work, env = workspace
    commands = parse_session(block)
    assert commands, f"{block.name}: a console block without a '$ ' command"
    for cmd in commands:
        proc = subprocess.run(
            ["bash", "-c", cmd.command],
            cwd=work,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            timeout=TIMEOUT_S,
        )
        where = f"{block.name.rsplit(':', 1)[0]}:{cmd.line}: $ {cmd.command}"
        assert proc.returncode == 0, f"{where}\nexited {proc.returncode}:\n{proc.stdout}"
        actual = proc.stdout.splitlines()
        assert output_matches(cmd.expected, actual), (
            f"{where}\nexpected:\n" + "\n".join(cmd.expected) + "\ngot:\n" + proc.stdout
        )


def test_readme_is_a_front_page() -> None:
    """The README stays short, and every Python or shell example in it is runnable."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines"
    loose = [
        b.name for b in parse_blocks(ROOT / "README.md") if b.lang in RUNNABLE and not b.runnable
    ]
    assert not loose, f"README blocks not marked 'run': {loose}"


def anchors(page: Path) -> set[str]:
    """The anchors GitHub makes for a page's headings: lower case, punctuation dropped,
    spaces to hyphens (code blocks skipped)."""
    out: set[str] = set()
    in_code = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if _FENCE.match(line):
            in_code = not in_code
        elif not in_code and line.startswith("#"):
            title = line.lstrip("#").strip().lower()
            out.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
    return out


def test_local_links_resolve() -> None:
    """Every relative link of the pages names a file of the repository, and every
    ``#anchor`` a heading of its page."""
    missing = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for target in _LINK.findall(text):
            if re.match(r"^[a-z]+:", target):
                continue
            file, _, anchor = target.partition("#")
            path = (page.parent / file).resolve() if file else page
            if not path.exists():
                missing.append(f"{page.relative_to(ROOT)}: {target}")
            elif anchor and path.suffix == ".md" and anchor not in anchors(path):
                missing.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not missing, "links to missing files or headings:\n" + "\n".join(missing)


# --- the checker itself ----------------------------------------------------------------


def test_output_matcher() -> None:
    """``...`` lines and ``...`` inside a line are wildcards; everything else is exact."""
    assert output_matches(["a", "b"], ["a", "b", ""])
    assert not output_matches(["a", "b"], ["a", "c"])
    assert not output_matches(["a"], ["a", "b"])
    assert output_matches(["a", "...", "z"], ["a", "z"])
    assert output_matches(["a", "...", "z"], ["a", "b", "c", "z"])
    assert not output_matches(["a", "...", "z"], ["a", "b"])
    assert output_matches(["took ... ms (egl)"], ["took 12.5 ms (egl)"])
    assert not output_matches(["took ... ms (egl)"], ["took 12.5 s (egl)"])
    assert output_matches(["x [1+2]"], ["x [1+2]"])  # regex characters are literal


def test_session_parser(tmp_path: Path) -> None:
    """A console block splits into commands, continuation lines and their outputs."""
    page = tmp_path / "p.md"
    page.write_text("x\n```console run\n$ echo a \\\n  b\na b\n\n$ true\n```\n")
    (block,) = parse_blocks(page)
    assert block.line == 2 and block.runnable and block.lang == "console"
    cmds = parse_session(block)
    assert [(c.line, c.command, c.expected) for c in cmds] == [
        (3, "echo a b", ["a b"]),
        (7, "true", []),
    ]


# --- renders/: the default output folder ------------------------------------------------

SAMPLE = ROOT / "renders" / "sample" / "showcase"
SAMPLE_MAX_BYTES = 300_000


def test_render_sample_is_small_and_whole() -> None:
    """renders/sample/ holds one small render: a contact sheet that decodes and the
    metrics of the same run (CSV rows = frames x effectors, as the JSON says)."""
    files = sorted(p.name for p in SAMPLE.iterdir())
    assert files == ["contact_sheet.png", "metrics.csv", "metrics.json"]
    assert sum(p.stat().st_size for p in SAMPLE.iterdir()) < SAMPLE_MAX_BYTES
    sheet = matplotlib.image.imread(SAMPLE / "contact_sheet.png")
    assert sheet.ndim == 3 and sheet.shape[0] > 100 and sheet[..., :3].std() > 0.05
    doc = json.loads((SAMPLE / "metrics.json").read_text(encoding="utf-8"))
    assert doc["scene"] == "showcase" and not doc["interrupted"]
    rows = (SAMPLE / "metrics.csv").read_text(encoding="utf-8").splitlines()[1:]
    assert len(rows) == doc["frames"] * len(doc["effectors"])
    assert "/" not in doc["source"][:1]  # a path inside the repository, not of a machine


def test_gitignore_keeps_only_the_renders_readme_and_sample() -> None:
    """git ignores every output under renders/ but its README and sample/."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    paths = ["renders/README.md", "renders/sample/showcase/metrics.json"]
    paths += ["renders/circle/circle.mp4", "renders/sweeps/x/summary.csv", "renders/x.png"]
    proc = subprocess.run(
        ["git", "check-ignore", "--no-index", *paths],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert proc.stdout.split() == paths[2:]
