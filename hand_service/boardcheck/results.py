"""One check's verdict, its measured values and the line it prints."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any


class Verdict(str, Enum):
    PASS = "PASS"
    FAIL = "FAIL"
    NOT_MADE = "N/A"  # the check cannot be made on this board (says why); not a failure


@dataclass
class CheckResult:
    name: str
    verdict: Verdict
    detail: str  # the measured values in words, or what went wrong
    values: dict[str, Any] = field(default_factory=dict)  # the measured values, for --json

    @property
    def failed(self) -> bool:
        return self.verdict == Verdict.FAIL

    def line(self) -> str:
        return f"{self.verdict.value:<4}  {self.name:<16} {self.detail}"

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "verdict": self.verdict.value, "detail": self.detail,
                "values": self.values}


def passed(name: str, detail: str, **values: Any) -> CheckResult:
    return CheckResult(name, Verdict.PASS, detail, values)


def failed(name: str, detail: str, **values: Any) -> CheckResult:
    return CheckResult(name, Verdict.FAIL, detail, values)


def not_made(name: str, detail: str, **values: Any) -> CheckResult:
    return CheckResult(name, Verdict.NOT_MADE, detail, values)


def verdict(name: str, ok: bool, detail: str, **values: Any) -> CheckResult:
    return CheckResult(name, Verdict.PASS if ok else Verdict.FAIL, detail, values)
