"""Every slot of the dispatch table has a golden test and a random-pair test.

The slots are read from the core's source: the item kinds of the table (`enum class ItemKind`, its
first kItemKinds names) paired with each other, and the static-only shapes (`static_only` in
cpp/src/geometry/shapes.cpp) against each item kind; so a kind added to the core fails here until
its tests exist. (A, B) and (B, A) are one slot. Which tests cover a slot is read from the tests
themselves: a Python test carries `@pytest.mark.slots("a-b", ..., role="golden" | "random",
note="...")` (on the function, or on a `pytest.param` of it), a C++ test a comment line
`// slots golden: a-b, c-d (note)` above its TEST(...). Not counted per slot:
NarrowPhase.EveryItemKindPairHasATestAndAnUnsetKindThrows (tests/cpp/test_contacts.cpp) runs every
item slot once (axis-aligned, gap and normal only), and test_crosscheck.py compares whole scenes
(boxes, spheres, meshes on planes) with the oracle.

    PYTHONPATH=python python3 tests/python/test_slot_coverage.py

prints the coverage table (slot -> golden tests; random-pair tests).
"""
import importlib
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TESTS = Path(__file__).resolve().parent
ROLES = ("golden", "random")
STATIC_NAMES = {"Plane": "plane", "TriangleMesh": "trimesh"}


def item_kinds():
    """The table's item kinds, lowercase, in the enum's order."""
    for header in sorted((ROOT / "cpp").rglob("*.hpp")):
        text = header.read_text()
        enum = re.search(r"enum class ItemKind\b[^{]*\{([^}]*)\}", text)
        if enum:
            count = int(re.search(r"kItemKinds\s*=\s*(\d+)", text).group(1))
            names = [n.strip() for n in enum.group(1).split(",") if n.strip()]
            return [n.lower() for n in names[:count]]
    raise AssertionError("no `enum class ItemKind` under cpp/")


def static_kinds():
    """The static-only shapes (always A), named as in the slots."""
    text = (ROOT / "cpp" / "src" / "geometry" / "shapes.cpp").read_text()
    body = re.search(r"bool static_only\([^)]*\)\s*\{(.*?)\n\}", text, re.S).group(1)
    return [STATIC_NAMES[n] for n in re.findall(r"holds_alternative<(\w+)>", body)]


def order():
    return static_kinds() + item_kinds()


def canonical(slot):
    """'polytope-sphere' -> 'sphere-polytope': the kinds in table order (static shapes first)."""
    kinds = order()
    a, b = slot.split("-")
    if a not in kinds or b not in kinds:
        raise AssertionError(f"unknown kind in slot {slot!r} (kinds: {kinds})")
    return f"{a}-{b}" if kinds.index(a) <= kinds.index(b) else f"{b}-{a}"


def table_slots():
    items, statics = item_kinds(), static_kinds()
    pairs = [f"{a}-{b}" for i, a in enumerate(items) for b in items[i:]]
    return [f"{s}-{k}" for s in statics for k in items] + pairs


def python_marks():
    """(test, role, slots, note) of every `slots` mark in tests/python/test_*.py."""
    if str(TESTS) not in sys.path:
        sys.path.insert(0, str(TESTS))
    found = []
    for path in sorted(TESTS.glob("test_*.py")):
        if "mark.slots" not in path.read_text():
            continue
        module = importlib.import_module(path.stem)
        for name, fn in vars(module).items():
            if not name.startswith("test_") or not callable(fn):
                continue
            for mark in getattr(fn, "pytestmark", []):
                if mark.name == "slots":
                    found.append((f"{path.stem}::{name}", mark))
                if mark.name == "parametrize":
                    for p in mark.args[1]:
                        for m in getattr(p, "marks", ()):
                            m = getattr(m, "mark", m)
                            if m.name == "slots":
                                pid = p.id or "-".join(str(v) for v in p.values)
                                found.append((f"{path.stem}::{name}[{pid}]", m))
    out = []
    for test, mark in found:
        role = mark.kwargs.get("role")
        assert role in ROLES, f"{test}: slots mark without role='golden' or 'random'"
        out.append((test, role, list(mark.args), mark.kwargs.get("note", "")))
    return out


CPP_TAG = re.compile(r"// slots (golden|random): ([^(]*?)(?: \((.*)\))?$")
CPP_TEST = re.compile(r"TEST(?:_F)?\((\w+), (\w+)\)")


def cpp_marks():
    """(test, role, slots, note) of every `// slots <role>: ...` line above a TEST in tests/cpp (other
    comment lines may lie between)."""
    out = []
    for path in sorted((ROOT / "tests" / "cpp").glob("*.cpp")):
        pending = []
        for number, line in enumerate(path.read_text().splitlines(), 1):
            tag = CPP_TAG.match(line)
            test = CPP_TEST.match(line)
            if tag:
                pending.append(tag.groups())
            elif test:
                for role, slots, note in pending:
                    out.append((f"{path.name}::{test[1]}.{test[2]}", role, [s.strip() for s in slots.split(",")],
                                note or ""))
                pending = []
            elif line.startswith("// slots"):
                raise AssertionError(f"{path.name}:{number}: not `// slots golden|random: a-b, ... (note)`")
            elif pending and not line.startswith("//"):
                raise AssertionError(f"{path.name}:{number}: a `// slots` line not above a TEST")
    return out


def coverage():
    """{slot: {role: [test (note), ...]}} over the table's slots."""
    table = {slot: {role: [] for role in ROLES} for slot in table_slots()}
    for test, role, slots, note in cpp_marks() + python_marks():
        for slot in slots:
            slot = canonical(slot)
            assert slot in table, f"{test}: {slot} is no slot of the table"
            entry = f"{test} ({note})" if note else test
            if entry not in table[slot][role]:  # a test naming (A, B) and (B, A)
                table[slot][role].append(entry)
    return table


def test_every_slot_has_a_golden_and_a_random_pair_test():
    missing = [f"{slot}: no {role} test" for slot, roles in coverage().items() for role in ROLES if not roles[role]]
    assert not missing, "; ".join(missing)


def test_the_slots_are_read_from_the_core():
    # the table as docs/conventions.md, "The dispatch table", describes it: 4 item kinds, 2 static shapes
    assert item_kinds() == ["sphere", "capsule", "cylinder", "polytope"]
    assert static_kinds() == ["plane", "trimesh"]
    assert len(table_slots()) == 18


def main():
    print("| slot | golden | random pairs |\n|---|---|---|")
    for slot, roles in coverage().items():
        print(f"| {slot} | {'<br>'.join(roles['golden'])} | {'<br>'.join(roles['random'])} |")


if __name__ == "__main__":
    main()
