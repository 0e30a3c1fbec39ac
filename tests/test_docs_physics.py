"""docs/physics.md: every citation of it resolves, every paper abbreviation is defined.

Plain Python (no numba, no vcavity import), so it runs even while the package is broken.

1. Every ``physics.md sec. N`` / ``sec. N-M`` / ``sec. N, M`` / ``section N`` /
   ``sections N and M`` (also split over a line break or a ``#`` comment continuation)
   in ``vcavity/``, ``scripts/``, ``tests/`` (*.py) and ``docs/*.md`` names sections that
   exist as ``## N. Title`` headings of docs/physics.md.
2. Every paper abbreviation cited in vcavity/ as ``ABBR eq. N``, ``ABBR sec. N``,
   ``ABBR fig. N`` or ``ABBR appendix X`` is defined in the references tables of
   docs/physics.md.
3. docs/physics.md is self-contained: it does not point at the shared design notes or
   the seed papers.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PHYSICS = ROOT / "docs" / "physics.md"

#: Topic words of the numbered sections; code cites these numbers, so they must not move.
SECTION_TOPICS = {
    1: "conventions",
    2: "distributions",
    3: "masking",
    4: "fresnel",
    5: "random walk",
    6: "sensor",
    7: "analytic",
    8: "identities",
    9: "pitfalls",
    10: "student",
}

_HEADING = re.compile(r"^## (\d+)\. (\S.*)$", re.MULTILINE)

# "physics.md", then anything that can sit between it and the section word when the
# citation is wrapped: whitespace, comment markers, quote/emphasis characters, a colon.
_GAP = r"[\s#>*\"'`(:,]*"
# A list of section numbers: "4", "4-9", "4 - 9", "4, 9", "4 and 7", "6 & 9", "4/9",
# "4 to 9", "4.2" (a subsection: its section is 4).
_NUM = r"\d+(?:\.\d+)*"
_SEP = r"\s*(?:,|-|–|—|/|&|\band\b|\bto\b|\bor\b)\s*"
_CITATION = re.compile(
    r"physics\.md" + _GAP
    + r"(?:(?P<word>§|secs?\b\.?|sections?\b|sect\b\.?)\s*)?"
    + r"(?P<nums>" + _NUM + r"(?:" + _SEP + _NUM + r")*)?",
    re.IGNORECASE,
)
_RANGE_SEP = re.compile(r"\s*(?:-|–|—|\bto\b)\s*", re.IGNORECASE)


def physics_sections(text: str) -> dict[int, str]:
    """``{number: title}`` of the ``## N. Title`` headings."""
    return {int(number): title.strip() for number, title in _HEADING.findall(text)}


def section_numbers(nums: str) -> list[int]:
    """Section numbers named by a list such as ``"4, 9"``, ``"6-9"``, ``"4 and 7"``."""
    numbers: list[int] = []
    # split on the non-range separators first, then expand ranges
    for part in re.split(r"\s*(?:,|/|&|\band\b|\bor\b)\s*", nums, flags=re.IGNORECASE):
        bounds = [b for b in _RANGE_SEP.split(part) if b]
        ints = [int(b.split(".")[0]) for b in bounds]
        if len(ints) == 2 and ints[0] <= ints[1] and ints[1] - ints[0] <= 20:
            numbers.extend(range(ints[0], ints[1] + 1))
        else:
            numbers.extend(ints)
    return numbers


def find_citations(text: str):
    """Yield ``(offset, numbers, snippet)`` for each citation of physics.md in ``text``.

    ``numbers`` is empty when a section word follows "physics.md" and is followed by a
    section label that is not a number ("sec. X", "section IV": an unresolvable
    citation); the template "physics.md sec. N" and prose such as "a physics.md
    section." are skipped. Mentions of physics.md with neither a section word
    nor a number right after it ("the formulas of physics.md directly") are not citations.
    """
    for match in _CITATION.finditer(text):
        word, nums = match.group("word"), match.group("nums")
        if not word and not nums:
            continue
        if not word and nums and not re.match(r"physics\.md[\s(]*\d", match.group(0)):
            # a bare number after a comma or colon belongs to other prose
            continue
        if word and not nums:
            after = text[match.end():]
            if re.match(r"N\b", after):
                continue  # a template ("physics.md sec. N") in prose about citations
            if not re.match(r"[A-Z]\b|[IVX]+\b", after):
                continue  # prose: "a physics.md section.", "the physics.md section on ..."
        numbers = section_numbers(nums) if nums else []
        snippet = " ".join(text[match.start():match.end() + 25].split())
        yield match.start(), numbers, snippet


def line_of(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def cited_files() -> list[Path]:
    files: list[Path] = []
    for folder in ("vcavity", "scripts", "tests"):
        files.extend(sorted((ROOT / folder).rglob("*.py")))
    files.extend(sorted((ROOT / "docs").glob("*.md")))
    this = Path(__file__).resolve()
    return [f for f in files if "__pycache__" not in f.parts and f.resolve() != this]


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


# --- abbreviations ------------------------------------------------------------------------

# ABBR eq. 12 / eqs. 4-8 / sec. 5.2 / section 3 / fig. 10 / appendix C (all-caps or "&").
_PAPER_CITATION = re.compile(
    r"(?<![\w&])(?P<abbr>[A-Z][A-Z&]{0,5})\.?\s+"
    r"(?:eqs?\.|equations?\b|secs?\.|sections?\b|figs?\.|figures?\b|appendix\b|app\.)\s*"
    r"(?P<ref>[0-9A-Z][0-9A-Za-z.]*)"
)


def defined_abbreviations(text: str) -> set[str]:
    """First-column entries of the tables in the "References and abbreviations" section."""
    match = re.search(r"^## References and abbreviations\s*$", text, re.MULTILINE)
    assert match, "docs/physics.md has no '## References and abbreviations' section"
    tail = text[match.end():]
    nxt = re.search(r"^## ", tail, re.MULTILINE)
    section = tail[: nxt.start()] if nxt else tail
    defined: set[str] = set()
    for row in re.findall(r"^\|(.+?)\|", section, re.MULTILINE):
        cell = row.strip().strip("`*").strip()
        if not cell or set(cell) <= set("-: ") or cell.lower() == "abbreviation":
            continue
        for name in re.split(r"\s*,\s*", cell):
            name = name.strip("`* ")
            if name:
                defined.add(name)
    return defined


def find_paper_citations(text: str):
    """Yield ``(offset, abbreviation, snippet)`` for each ``ABBR eq./sec./fig./appendix``."""
    for match in _PAPER_CITATION.finditer(text):
        snippet = " ".join(text[match.start():match.end() + 10].split())
        yield match.start(), match.group("abbr"), snippet


# --- tests --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def physics_text() -> str:
    assert PHYSICS.is_file(), "docs/physics.md is missing"
    return PHYSICS.read_text(encoding="utf-8")


def test_sections_are_numbered_as_the_code_cites_them(physics_text):
    sections = physics_sections(physics_text)
    numbers = [int(n) for n, _ in _HEADING.findall(physics_text)]
    assert numbers == sorted(set(numbers)), f"section numbers out of order or repeated: {numbers}"
    wrong = {n: sections.get(n) for n, topic in SECTION_TOPICS.items()
             if n not in sections or topic not in sections[n].lower()}
    assert not wrong, f"sections missing or renamed (number: title found): {wrong}"


def test_every_physics_citation_resolves(physics_text):
    sections = physics_sections(physics_text)
    unresolved, count = [], 0
    for path in cited_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for offset, numbers, snippet in find_citations(text):
            count += 1
            missing = [n for n in numbers if n not in sections] or ([] if numbers else ["?"])
            if missing:
                unresolved.append(f"{_rel(path)}:{line_of(text, offset)}: {snippet!r} "
                                  f"-> no section {', '.join(map(str, missing))}")
    assert count > 50, f"only {count} citations found: is the parser broken?"
    assert not unresolved, (
        f"{len(unresolved)} citation(s) of docs/physics.md do not resolve "
        f"(sections present: {sorted(sections)}):\n" + "\n".join(unresolved))


def test_every_cited_paper_abbreviation_is_defined(physics_text):
    defined = defined_abbreviations(physics_text)
    undefined, count = [], 0
    for path in sorted((ROOT / "vcavity").rglob("*.py")):
        text = path.read_text(encoding="utf-8", errors="replace")
        for offset, abbr, snippet in find_paper_citations(text):
            count += 1
            if abbr not in defined:
                undefined.append(f"{_rel(path)}:{line_of(text, offset)}: {abbr!r} in {snippet!r}")
    assert count > 50, f"only {count} paper citations found in vcavity/: is the parser broken?"
    assert not undefined, (
        f"{len(undefined)} paper abbreviation(s) cited in vcavity/ are not defined in the "
        f"references of docs/physics.md (defined: {sorted(defined)}):\n" + "\n".join(undefined))


def test_internal_cross_references_resolve(physics_text):
    sections = physics_sections(physics_text)
    bad = [f"docs/physics.md:{line_of(physics_text, m.start())}: §{m.group(1)}"
           for m in re.finditer(r"§(\d+)", physics_text) if int(m.group(1)) not in sections]
    assert not bad, "cross-references to missing sections:\n" + "\n".join(bad)


def test_physics_md_does_not_depend_on_shared_material(physics_text):
    found = [f"docs/physics.md:{line_of(physics_text, m.start())}: {m.group(0)!r}"
             for m in re.finditer(r"/work/shared|shared/design|seeds/", physics_text)]
    assert not found, "docs/physics.md must be self-contained:\n" + "\n".join(found)


# --- the parsers themselves ---------------------------------------------------------------


@pytest.mark.parametrize("text, expected", [
    ("(physics.md sec. 4)", [4]),
    ("physics.md sec. 4, 9)", [4, 9]),
    ("physics.md sec. 6-9", [6, 7, 8, 9]),
    ("physics.md sec. 2-4, 7)", [2, 3, 4, 7]),
    ("physics.md sections 6 and 9", [6, 9]),
    ("physics.md section 9, \"Projected solid angle\"", [9]),
    ("physics.md sec. 4, \"Limits\"", [4]),
    ("physics.md sec. 4, limits)", [4]),
    ("(physics.md\n    sec. 9: 1.6 % at alpha = 3", [9]),
    ("# tails (physics.md\n# sec. 9: 1.6 %", [9]),
    ("physics.md sec. 4 and 7, flat limit", [4, 7]),
    ("(physics.md 4)", [4]),
    ("physics.md sec. 42", [42]),
    ("physics.md sec. 4.2", [4]),
])
def test_citation_parser(text, expected):
    found = list(find_citations(text))
    assert len(found) == 1 and found[0][1] == expected, found


@pytest.mark.parametrize("text", [
    "The references below are written from the formulas of physics.md directly",
    "a qualitative fit and physics.md\nexpects \"a few percent\"",
])
def test_parser_ignores_plain_mentions(text):
    assert list(find_citations(text)) == []


def test_parser_flags_a_citation_without_number():
    assert [n for _, n, _ in find_citations("see physics.md sec. X")] == [[]]
    assert list(find_citations('cite it as "physics.md sec. N"')) == []  # a template
    assert list(find_citations("citing a `docs/physics.md` section.\n2. Add")) == []  # prose


def test_abbreviation_parser():
    text = "W eq. 22, IL eq. 4-8, H sec. 5, H appendix C, H fig. 10-11, XYZ eq. 3, see eq. 4, (A&S eq. 4.4.49)"
    assert [a for _, a, _ in find_paper_citations(text)] == ["W", "IL", "H", "H", "H", "XYZ", "A&S"]
