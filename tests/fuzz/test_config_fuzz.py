"""Fuzzed profiles and model files: every bad one is a one-line UserError."""

from __future__ import annotations

from pathlib import Path

from hypothesis import strategies as st

import rtcore
from hand_service.config.profile import load_model, load_profile
from tests.fuzz.conftest import (
    BUS_PROFILE_TEXT,
    CAN_PROFILE_TEXT,
    GEOMETRY_MODEL_TEXT,
    MODEL_DOC,
    MODEL_TEXT,
    PROFILE_DOC,
    PROFILE_TEXT,
    fuzz_tests,
    refused_in_one_line,
)
from tests.fuzz.strategies import encoded, mutated_tree_text, mutated_yaml_text, raw_bytes

PROFILES = st.one_of(
    mutated_yaml_text(PROFILE_TEXT).flatmap(encoded),
    mutated_yaml_text(PROFILE_TEXT).flatmap(encoded),
    mutated_tree_text(PROFILE_DOC).flatmap(encoded),
    mutated_yaml_text(BUS_PROFILE_TEXT).flatmap(encoded),
    st.integers(0, 9).flatmap(lambda n: mutated_yaml_text(CAN_PROFILE_TEXT) if n == 0
                              else mutated_yaml_text(BUS_PROFILE_TEXT)).flatmap(encoded),
    raw_bytes(),
)
MODELS = st.tuples(
    st.one_of(mutated_yaml_text(MODEL_TEXT).flatmap(encoded), mutated_yaml_text(MODEL_TEXT).flatmap(encoded),
              mutated_tree_text(MODEL_DOC).flatmap(encoded),
              mutated_yaml_text(GEOMETRY_MODEL_TEXT).flatmap(encoded),
              mutated_yaml_text(PROFILE_TEXT).flatmap(encoded), raw_bytes()),
    st.sampled_from([None, None, "index", "thumb", "", "\x00"]))


def check_profile(fuzz_dir: Path, data: bytes) -> None:
    path = fuzz_dir / "fuzzed.yaml"
    path.write_bytes(data)

    def load() -> None:
        profile = load_profile(path)
        rtcore.Hand(profile.hand_config())  # a profile that loads, the control core accepts

    refused_in_one_line(load)


def check_model(fuzz_dir: Path, case: tuple[bytes, str | None]) -> None:
    data, finger = case
    path = fuzz_dir / "model.yaml"
    path.write_bytes(data)
    refused_in_one_line(lambda: load_model(path, finger))


test_profile_fuzz, test_profile_fuzz_full = fuzz_tests(PROFILES, check_profile)
test_model_fuzz, test_model_fuzz_full = fuzz_tests(MODELS, check_model)
