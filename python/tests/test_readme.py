"""The code on the first page (README.md) and in the user guide (docs/guide.md), run as a reader
would run it, so that neither page can rot.

Each page's blocks run in order in a fresh folder that holds the repository's `scenes/` and
`shaders/` (as links), the way a reader runs them from a checkout:
- every ```python block is executed on its own, and the test fails if it raises;
- every line of a ```sh block that calls `target/release/raycast` runs, with the binary that
  `cargo test` built standing in for the release build (RAYCAST_BIN to use another); the
  other lines must be listed in ELSEWHERE with what runs them instead;
- a ```json block is parsed, and saved where the page says to save it (SAVED_AS);
- ```rust blocks are the README's doc tests (src/lib.rs includes README.md), run by
  `cargo test`; anywhere else, and in any block without a language, they would be tested by
  nothing, so they fail here.
"""

import json
import os
import pathlib
import re
import shlex
import signal
import subprocess
import urllib.request

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BINARY = os.environ.get("RAYCAST_BIN", str(ROOT / "target" / "debug" / "raycast"))
RAYCAST = "target/release/raycast"

# Shell lines these tests do not run, and why that is enough.
ELSEWHERE = {
    # The contract's two commands. .ci/run runs scripts/test.sh (which runs these tests), after
    # the steps of scripts/setup.sh but for its release build and render.
    "scripts/setup.sh": "the setup command",
    "scripts/test.sh": "the suite itself",
    # scripts/test.sh installs the package exactly so before running pytest.
    "pip install ./python": "scripts/test.sh",
}

# Where a page tells the reader to save its JSON blocks, by page and block number (from 0).
SAVED_AS = {("docs/guide.md", 0): "myscene.json", ("docs/guide.md", 1): "together.json"}

# The guide's scene names a mesh, `mymesh.obj`, the reader brings: a unit cube at the origin.
CUBE_OBJ = "\n".join(
    [f"v {x - 0.5} {y - 0.5} {z - 0.5}" for z in (0, 1) for y in (0, 1) for x in (0, 1)]
    + [
        "f 1 3 2", "f 2 3 4", "f 5 6 7", "f 6 8 7",  # z = -0.5 and +0.5
        "f 1 2 5", "f 2 6 5", "f 3 7 4", "f 4 7 8",  # y = -0.5 and +0.5
        "f 1 5 3", "f 3 5 7", "f 2 4 6", "f 4 8 6",  # x = -0.5 and +0.5
    ]
) + "\n"

PAGES = ["README.md", "docs/guide.md"]


def blocks(page):
    """The page's fenced code blocks: (language, line number of the fence, text)."""
    found, lang, start, body = [], None, 0, []
    for number, line in enumerate((ROOT / page).read_text().splitlines(), 1):
        if lang is None and line.startswith("```"):
            lang, start, body = line[3:].strip(), number, []
        elif lang is not None and line.startswith("```"):
            found.append((lang, start, "\n".join(body) + "\n"))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"{page}:{start}: a code block is not closed"
    return found


def run_shell(page, start, text, folder):
    for offset, line in enumerate(text.splitlines(), 1):
        where = f"{page}:{start + offset}"
        words = shlex.split(line, comments=True)
        if not words or " ".join(words) in ELSEWHERE:
            continue
        assert words[0] == RAYCAST, f"{where}: nothing tests this line: {line}"
        if words[1] == "serve":
            run_server(where, words, folder)
            continue
        result = subprocess.run(
            [BINARY, *words[1:]], cwd=folder, capture_output=True, text=True, timeout=600
        )
        assert result.returncode == 0, (
            f"{where}: {line}\nexit code {result.returncode}\n{result.stdout}{result.stderr}"
        )


def run_server(where, words, folder):
    """A `raycast serve` line: on any free port, it serves the page and a frame, and stops on
    Ctrl-C (SIGINT) with exit code 0."""
    server = subprocess.Popen(
        [BINARY, *words[1:], "--port", "0"], cwd=folder, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )
    try:
        first = server.stdout.readline()
        assert first.startswith("serving http://"), f"{where}: {first}{server.stderr.read()}"
        url = first.split()[1]
        for path in ("", "frame?tab=color"):
            with urllib.request.urlopen(url + path, timeout=120) as answer:
                assert answer.status == 200, f"{where}: {url}{path}"
    finally:
        server.send_signal(signal.SIGINT)
        code = server.wait(timeout=60)
    assert code == 0, f"{where}: exit code {code}"


@pytest.mark.parametrize("page", PAGES)
def test_every_code_block_runs(page, tmp_path, monkeypatch):
    for name in ("scenes", "shaders"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    (tmp_path / "mymesh.obj").write_text(CUBE_OBJ)
    monkeypatch.chdir(tmp_path)
    json_blocks = 0
    ran = 0
    for lang, start, text in blocks(page):
        where = f"{page}:{start}"
        if lang == "python":
            exec(compile(text, where, "exec"), {"__name__": "__main__"})
        elif lang == "sh":
            run_shell(page, start, text, tmp_path)
        elif lang == "json":
            json.loads(text)
            saved_as = SAVED_AS.get((page, json_blocks))
            if saved_as:
                (tmp_path / saved_as).write_text(text)
            json_blocks += 1
        elif lang == "rust" and page == "README.md":
            pass  # a doc test of the crate: `cargo test` runs it
        elif lang != "text":
            pytest.fail(f"{where}: a ```{lang} block that nothing tests")
        ran += 1
    assert ran > 0, f"{page} has no code blocks"


def test_the_readme_is_a_first_page():
    text = (ROOT / "README.md").read_text()
    lines = text.splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines; a first page has at most 200"
    # A commit hash: 7 to 40 hex digits, with a letter and a digit among them.
    hashes = re.findall(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b", text)
    assert not hashes, f"README.md names commits: {hashes}"
