"""docs/profiles.md is generated from the schema; the committed file must be current."""

from __future__ import annotations

from hand_service.config.profile import ROOT, all_sections
from hand_service.config.profile_docs import render


def test_committed_profile_docs_are_up_to_date() -> None:
    committed = (ROOT / "docs" / "profiles.md").read_text()
    assert committed == render(), "regenerate: python -m hand_service.config.profile_docs > docs/profiles.md"


def test_every_key_is_documented_with_unit_range_default() -> None:
    text = render()
    for section in all_sections():
        for key in section.keys:
            assert f"| `{key.name}` |" in text
    assert "## Transport: can" in text and "## Transport: serial" in text
