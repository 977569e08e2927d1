"""Helpers shared between test files and benchmarks live in tests/python/helpers.py: no test file
or benchmark imports another test file (test_slot_coverage.py reads the tests' marks, not their
helpers)."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
IMPORT = re.compile(r"^\s*(?:from\s+test_\w+\s+import|import\s+test_\w+)|spec_from_file_location\([^)]*test_\w+", re.M)


def test_no_test_file_or_benchmark_imports_another_test_file():
    offenders = [f"{path.relative_to(ROOT)}: {m.group(0).strip()}"
                 for path in sorted((ROOT / "tests" / "python").glob("*.py")) + sorted((ROOT / "benchmarks").glob("*.py"))
                 for m in IMPORT.finditer(path.read_text())]
    assert not offenders, "import from tests/python/helpers.py instead: " + "; ".join(offenders)
