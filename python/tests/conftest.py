"""What the package's tests share: where the bundled data and the fishcam program are.

CTest sets FISHCAM_DATA_DIR and FISHCAM_BINARY (tests/CMakeLists.txt); run by hand,
the data falls back to the source tree's data/ and tests that need the program skip.
Test modules import the constants (``from conftest import DATA``) or take the
fixtures.
"""

import os
from pathlib import Path
from typing import Any

import pytest

# The bundled cameras (data/ of the source tree).
DATA = os.environ.get("FISHCAM_DATA_DIR", str(Path(__file__).resolve().parents[2] / "data"))
# The fishcam program under test, or None.
BINARY = os.environ.get("FISHCAM_BINARY")
# ../shared beside the source tree: real calibration files and photos (the tests that
# read them skip without it; their CTest entries carry the label real-data).
SHARED = Path(__file__).resolve().parents[3] / "shared"


@pytest.fixture(scope="session")
def fishcam_binary() -> str:
    """The fishcam program; skips the test when CTest did not say where it is."""
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    return BINARY


def pytest_terminal_summary(terminalreporter: Any) -> None:
    """Appends each skipped test and its reason to FISHCAM_SKIP_LOG (scripts/test.sh
    counts them: the tests of ../shared's real files skip without it)."""
    log = os.environ.get("FISHCAM_SKIP_LOG")
    if not log:
        return
    lines = []
    for report in terminalreporter.stats.get("skipped", []):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        lines.append(f"{report.nodeid}\t{reason.removeprefix('Skipped: ')}\n")
    if lines:
        with open(log, "a", encoding="utf-8") as out:  # one write per test file: CTest runs them in parallel
            out.write("".join(lines))
