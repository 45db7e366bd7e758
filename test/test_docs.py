"""The project's documents are self-contained: every ``docs/<file>`` a source, config or
document names exists, every ``§N`` it cites is a numbered heading of that file, and
nothing points outside the repository."""
import re
import subprocess
from pathlib import Path

from drill_core.rig_root import rig_root

ROOT = rig_root()
REFERENCE = re.compile(r"docs/([A-Za-z0-9_.-]+\.(?:md|png|json))(?:`?\s*§(\d+))?")


def _tracked_text_files() -> list[Path]:
    names = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    return [ROOT / n for n in names if n.endswith((".py", ".md", ".yaml", ".sh", ".html"))
            or n.startswith("scripts/")]


def _sections(doc: Path) -> set[str]:
    return set(re.findall(r"^#+\s+(\d+)\.", doc.read_text(encoding="utf-8"), re.M))


def test_every_docs_reference_resolves():
    broken = []
    for path in _tracked_text_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for name, section in REFERENCE.findall(text):
            doc = ROOT / "docs" / name
            if not doc.exists():
                broken.append(f"{path.relative_to(ROOT)}: docs/{name} does not exist")
            elif section and section not in _sections(doc):
                broken.append(f"{path.relative_to(ROOT)}: docs/{name} has no section {section}")
    assert not broken, "\n".join(broken)


def test_nothing_points_outside_the_repository():
    outside = re.compile(r"\.\./shared|DESIGN\.md|DESIGN section")
    hits = [f"{p.relative_to(ROOT)}" for p in _tracked_text_files()
            if p != Path(__file__).resolve()
            and outside.search(p.read_text(encoding="utf-8", errors="replace"))]
    assert not hits, hits
