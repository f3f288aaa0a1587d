"""The deck reference in docs/ is generated from the schema and in step."""

from fsph.deck import reference_markdown
from conftest import REPO


def test_deck_reference_in_step():
    assert (REPO / "docs" / "decks.md").read_text() == reference_markdown(), \
        "docs/decks.md is stale: run `make docs`"
