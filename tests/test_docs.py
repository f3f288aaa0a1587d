"""The deck reference in docs/ is generated from the schema and in step."""

from fsph.deck import reference_markdown
from conftest import REPO


def test_deck_reference_in_step():
    assert (REPO / "docs" / "decks.md").read_text() == reference_markdown(), \
        "docs/decks.md is stale: run `make docs`"


def test_every_python_module_is_installed():
    """meson.build names the installed modules one by one; a module missing
    there works from the checkout and fails after `make run` installs."""
    import re
    listed = set(re.findall(r"'(fsph/[a-z_0-9]+\.py)'", (REPO / "meson.build").read_text()))
    present = {f"fsph/{p.name}" for p in (REPO / "fsph").glob("*.py")}
    assert present == listed
