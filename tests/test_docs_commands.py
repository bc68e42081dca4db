"""Every `python3 -m cli ...` command of README.md and docs/*.md parses with the real
parsers, as written (nothing runs): in code blocks (shell variables of the block expanded,
continued lines and quoted values over lines joined) and in inline code, even across lines of prose. A placeholder value
(S, N, DIR, ...) stands for a valid one of its option (PLACEHOLDERS); `[...]` is optional
(its content is parsed), `a|b` a choice (the first is parsed)."""
import contextlib
import io
import re
import shlex
from pathlib import Path

import pytest

from cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
# a value written as a placeholder, by option: one the option takes
PLACEHOLDERS = {"--scale": "small", "--seed": "1", "--seeds": "1,2", "--impactor-speed": "10",
                "--steps": "100", "--threads": "1", "--jobs": "1", "--mpi": "3",
                "--diagonal-relaxation": "35", "--relaxation": "35", "--dt-safety": "0.3",
                "--shear-release": "1e-4", "--de-zone": "0.5", "--ratio": "5", "--layers": "1"}
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9_]*$")


COMMAND = re.compile(r"^(?: {4}|\t)\s*(?:[A-Z_]+=\"|(?:/usr/bin/)?python3 |mpirun )")


def commands(page):
    """(line, argv text after `-m cli`) of every command in the page."""
    text = page.read_text()
    found, prose = [], text
    for block in re.finditer(r"^```[^\n]*\n(.*?)^```", text, re.M | re.S):
        found += _block(text, block.start(1), block.group(1))
        prose = _blank(prose, block.start(), block.end())
    for line in re.finditer(r"^.*$", prose, re.M):      # indented command lines
        if COMMAND.match(line.group(0)):
            found += _block(text, line.start(), line.group(0))
            prose = _blank(prose, line.start(), line.end())
    for span in re.finditer(r"`([^`]+)`", prose):
        if "-m cli " in span.group(1) or "-m bench.worker " in span.group(1):
            found.append((_line(text, span.start()), " ".join(span.group(1).split())))
    return found


def _blank(text, start, end):
    """`text` with [start, end) made spaces, its line breaks kept."""
    return text[:start] + re.sub(r"[^\n]", " ", text[start:end]) + text[end:]


def _block(text, start, body):
    """The commands of a code block, its variables (NAME="...") expanded."""
    out, names, lines = [], {}, body.split("\n")
    i = 0
    while i < len(lines):
        n, line = _line(text, start) + i, lines[i]
        while line.rstrip().endswith("\\") and i + 1 < len(lines):
            i += 1
            line = line.rstrip()[:-1] + " " + lines[i].strip()
        while line.count("'") % 2 and i + 1 < len(lines):     # a quoted value goes on
            i += 1
            line += " " + lines[i].strip()
        i += 1
        assigned = re.match(r"^\s*([A-Z_]+)=\"([^\"]*)\"", line)
        if assigned:
            names[assigned[1]] = assigned[2]
            continue
        for name, value in names.items():
            line = line.replace(f"${name}", value)
        out.append((n, line.strip()))
    return out


def _line(text, at):
    return text.count("\n", 0, at) + 1


def argv_of(command):
    """The argv a documented command stands for (None: a mention, not a command)."""
    command = re.split(r"\s#|\s\|\||\s&&", command)[0]
    command = command.replace("[", " ").replace("]", " ")
    words = [w.split("|")[0] for w in shlex.split(command) if w not in ("...", "…")]
    if len(words) < 2 or PLACEHOLDER.match(words[0]):
        return None                     # `python3 -m cli slab`, `SUBCOMMAND …`: a mention
    for k in range(1, len(words)):
        if words[k - 1] in PLACEHOLDERS and PLACEHOLDER.match(words[k]):
            words[k] = PLACEHOLDERS[words[k - 1]]
    return words


def cli_commands(page):
    """(line, argv text after `-m cli`) of the page's CLI commands."""
    return [(n, c.split("-m cli ", 1)[1]) for n, c in commands(page) if "-m cli " in c]


def worker_tasks(page):
    """(line, task text) of the page's `-m bench.worker '<task>'` commands."""
    return [(n, shlex.split(c.split("-m bench.worker ", 1)[1])[0]) for n, c in commands(page)
            if "-m bench.worker '" in c]


CASES = [(page, line, command) for page in PAGES for line, command in cli_commands(page)]
TASKS = [(page, line, task) for page in PAGES for line, task in worker_tasks(page)]


def test_the_pages_have_commands_and_run_them_with_the_readme_s_interpreter():
    """`/usr/bin/python3`, the README's: the first `python3` on a fresh machine's PATH may
    lack the stack."""
    assert len(CASES) > 80
    for page in PAGES:
        for n, line in enumerate(page.read_text().splitlines(), 1):
            assert not re.search(r"(?<![/\w.-])python3 -m", line), f"{page.name}:{n}: {line}"


@pytest.mark.parametrize("page, line, command", CASES,
                         ids=[f"{p.name}:{n}" for p, n, _ in CASES])
def test_a_documented_command_parses_as_written(page, line, command):
    argv = argv_of(command)
    if argv is None:
        return
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            build_parser().parse_args(argv)
    except SystemExit:
        pytest.fail(f"{page.relative_to(ROOT)}:{line}: `{command}`: {err.getvalue().strip()}")


@pytest.mark.parametrize("page, line, task", TASKS, ids=[f"{p.name}:{n}" for p, n, _ in TASKS])
def test_a_documented_worker_task_has_the_worker_s_keys(page, line, task):
    import json
    from bench.worker import check_task
    try:
        check_task(json.loads(task))
    except ValueError as e:
        pytest.fail(f"{page.relative_to(ROOT)}:{line}: {e}")


def test_worker_tasks_are_found_and_a_bad_one_is_one_line(capsys):
    """The pages' tasks are read (three, on two pages); a task with an unknown key, a
    missing one or a spec field that does not exist gets one line naming it, exit 2."""
    from bench.worker import main
    assert len(TASKS) >= 3
    for task, words in (('{"scale": "small", "model": "full", "warmup": 1, "step": 2}',
                         ("unknown key(s) step", "missing steps")),
                        ('{"model": "full", "warmup": 1, "steps": 2}', ("missing scale",)),
                        ('{"scale": "small", "model": "fe", "warmup": 1, "steps": 2}',
                         ("model = 'fe'",)),
                        ('{"model": "full", "warmup": 1, "steps": 2, "spec": {"sacle": 1}}',
                         ("no SlabSpec field sacle",)),
                        ("[1]", ("must be a JSON object",)), ("{", ("not JSON",))):
        assert main([task]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and all(w in err for w in words), err
