"""Short answers first (issue 25): the students' pages read short, and every exercise answers with a short lesson.

The pages are measured the way ../shared/tools/prose-metrics measures them: words of prose (outside code blocks,
tables and pictures), each paragraph's numerals per sentence, the longest sentence. Each exercise is run as
ANSWERS.md runs it, without --more: after its verdict a lesson of at most LESSON_WORDS words, the one ANSWERS.md
pastes (so the spoiler test in tests/test_docs.py reads it), then the Next line, last.
"""

import re
import shlex
import subprocess
import sys

import pytest
from test_docs import answers_with_their_commands

from conftest import REPO
from curriculum.common.predict import MORE

NUMERAL = r"(?<![\w.])[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?%?"  # 2,000, 0.032%, 5.1e-11; not RK4, not "four"
WORD = r"[A-Za-z0-9][\w'.,%/-]*"
LESSON_WORDS = 120
ANSWERS = (REPO / "exercises" / "solutions" / "ANSWERS.md").read_text()


def prose(text: str) -> str:
    """The page without its code blocks, tables and pictures."""
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return "\n".join(line for line in text.splitlines()
                     if not line.lstrip().startswith("|") and not line.startswith("!["))


def measure(text: str) -> dict:
    """{words, densest: (numerals per sentence, paragraph), longest: (words, sentence)}, as prose-metrics counts."""
    text = prose(text)
    densest, longest = (0.0, ""), (0, "")
    for paragraph in re.split(r"\n\s*\n", text):
        if not paragraph.strip() or paragraph.strip().startswith("#"):
            continue
        flat = paragraph.replace("\n", " ")
        sentences = [s for s in re.split(r"(?<=[.!?:])\s+(?=[A-Z(`*])", flat) if len(s.split()) > 3]
        if not sentences:
            continue
        density = len(re.findall(NUMERAL, flat)) / len(sentences)
        densest = max(densest, (density, flat[:80]))
        longest = max(longest, *((len(s.split()), s[:80]) for s in sentences))
    return {"words": len(re.findall(WORD, text)), "densest": densest, "longest": longest}


def test_the_measure_counts_as_the_issue_does():
    page = ("# Title\n\nOne two three four five. The run took 2,000 steps of 0.01 s: RK4 kept 5.1e-11.\n\n"
            "```bash\npython engine.py --steps 123\n```\n\n| a | 1 |\n|---|---|\n\n![a picture](x.png)\n")
    measured = measure(page)
    assert measured["words"] == 1 + 5 + 11  # the heading counts; the code, the table and the picture do not
    # 3 numerals in 2 sentences: "RK4 kept 5.1e-11." is too short to count as one, and its numeral counts
    assert measured["densest"][0] == 1.5 and measured["longest"][0] == 8


def test_the_measure_is_the_issues_tool_where_it_is_installed():
    """The course's machines keep the issue's own tool beside the checkout (../shared/tools/prose-metrics)."""
    tool = REPO.parent / "shared" / "tools" / "prose-metrics"
    if not tool.is_file():
        pytest.skip(f"{tool} is not on this machine: test_the_measure_counts_as_the_issue_does stands for it")
    pages = ["README.md", "exercises/README.md"]
    said = subprocess.run([sys.executable, str(tool), *pages], cwd=REPO, capture_output=True, text=True,
                          timeout=60).stdout.splitlines()
    for page, line in zip(pages, said, strict=True):
        measured = measure((REPO / page).read_text())
        assert line == (f"{page}: {measured['words']} words; densest paragraph {measured['densest'][0]:.1f}"
                        f" numerals/sentence; longest sentence {measured['longest'][0]} words")


@pytest.mark.parametrize("page, most_words", [
    ("README.md", 900),
    ("exercises/README.md", 800)])
def test_a_students_page_reads_short(page, most_words):
    """At most `most_words` words of prose, every paragraph at most 2 numerals a sentence on average, no sentence
    over 40 words."""
    measured = measure((REPO / page).read_text())
    assert measured["words"] <= most_words, f"{page}: {measured['words']} words of prose, over {most_words}"
    density, paragraph = measured["densest"]
    assert density <= 2.0, f"{page}: {density:.1f} numerals a sentence in the paragraph {paragraph!r}"
    words, sentence = measured["longest"]
    assert words <= 40, f"{page}: a sentence of {words} words: {sentence!r}"


# The longer runs (exercise 4 measures for a few seconds) are timed elsewhere; the quick ones run every time.
SLOW = ("ex4_long_run",)


@pytest.mark.parametrize("command, pasted", [
    pytest.param(command, pasted, marks=pytest.mark.slow if any(s in command for s in SLOW) else ())
    for command, pasted in answers_with_their_commands()])
def test_each_exercise_answers_with_a_short_lesson_then_the_next_line(command, pasted):
    """Without --more: the verdict, a lesson of at most LESSON_WORDS words (the same lesson --more starts with,
    pasted in ANSWERS.md) and the Next line, last. Exercise 2's checker says "All solved." and then Next."""
    argv = [word for word in shlex.split(command)[1:] if word != "--more"]
    result = subprocess.run([sys.executable, *argv], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    lines = result.stdout.rstrip("\n").splitlines()
    assert lines[-1].startswith("Next: "), f"{command}: the run does not end with its Next line"
    if "check_ex" in command:
        assert lines[-2] == "All solved.", command
        return
    verdict = max(i for i, line in enumerate(lines) if line.startswith(("Right: ", "Not quite: ")))
    lesson = lines[verdict + 1:-1]
    words = len(re.findall(WORD, "\n".join(lesson)))
    assert words <= LESSON_WORDS, f"{command}: a lesson of {words} words, over {LESSON_WORDS}"
    assert lesson[-1] == MORE and "--more" in command  # where the rest is, and ANSWERS.md pastes the rest
    shown = "\n".join(lines[: verdict + 1] + lesson[:-1])
    assert pasted.startswith(shown + "\n"), f"{command}: ANSWERS.md pastes another lesson than the run prints"
