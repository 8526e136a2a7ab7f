"""The benches' library and the tables generated from their results.

Bench scripts share bench/benchlib and import no other script; each writes
its results as JSON (benchlib.results), and the tables in docs/ marked as
generated are those results, rendered (scripts/gen_bench_tables.py).
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "bench"
sys.path.insert(0, str(BENCH))

from benchlib.results import Results  # noqa: E402
from benchlib.tables import TableError, update  # noqa: E402

#: Scripts that are parts of another bench and write no results of their
#: own: the STARK side (run in pystark's interpreter), the yasps side of the
#: same comparison, and the GPU kit writer (its output is a kit for
#: runtime/bench, timed elsewhere).
PARTS = {"stark_driver", "stark_yasps_side", "gpu_kit"}


def scripts() -> list[Path]:
    return sorted(BENCH.glob("*.py"))


def imported_modules(path: Path) -> set[str]:
    """The top-level names of the modules a file imports."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_scripts_import_the_library_and_no_other_script():
    names = {p.stem for p in scripts()}
    for path in scripts() + sorted((BENCH / "benchlib").glob("*.py")):
        shared = imported_modules(path) & names
        assert not shared, f"{path.relative_to(ROOT)} imports bench " \
            f"script(s) {sorted(shared)}: move what they share to benchlib"


def test_every_bench_writes_its_results():
    for path in scripts():
        if path.stem in PARTS:
            continue
        text = path.read_text()
        assert f'add_json_argument(parser, "{path.stem}")' in text, \
            f"{path.name} takes no --json for its results"
        assert f'Results("{path.stem}")' in text, \
            f"{path.name} writes no benchlib.results.Results"


def test_the_documents_show_the_current_results():
    done = subprocess.run([sys.executable, str(ROOT / "scripts" /
                                               "gen_bench_tables.py"),
                           "--check"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def write(folder: Path, bench: str, rows) -> None:
    results = Results(bench, command=["--x"])
    results.table("speed", ["scene", "s/frame", "ratio"], rows,
                  ["", "{:.3f}", "{:.2f}x"], note="A note.")
    results.write(folder / f"{bench}.json")


DOC = """# Title
Prose stays.
<!-- bench-table: peer speed -->
| stale | table |
<!-- /bench-table -->
More prose.
"""


def test_a_marked_table_is_regenerated_from_its_results(tmp_path):
    write(tmp_path, "peer", [["A", 0.1234, 1.333], ["B", None, 2.0]])
    text, used = update(DOC, tmp_path)
    assert used == ["peer speed"]
    assert "| stale | table |" not in text
    assert text.startswith("# Title\nProse stays.\n<!-- bench-table: peer speed -->\n")
    assert text.endswith("<!-- /bench-table -->\nMore prose.\n")
    assert "| scene | s/frame | ratio |" in text
    assert "|---|---:|---:|" in text
    assert "| A | 0.123 | 1.33x |" in text
    assert "| B |  | 2.00x |" in text
    assert "A note." in text and "`python3 bench/peer.py --x`" in text
    # Regenerating what was generated changes nothing.
    assert update(text, tmp_path)[0] == text
    # New results change the table.
    write(tmp_path, "peer", [["A", 0.2, 1.0]])
    assert "| A | 0.200 | 1.00x |" in update(text, tmp_path)[0]


def test_a_marker_without_results_is_an_error(tmp_path):
    with pytest.raises(TableError, match="no results peer.json"):
        update(DOC, tmp_path, "doc.md")
    write(tmp_path, "peer", [["A", 1.0, 1.0]])
    with pytest.raises(TableError, match="has no table 'other'.*speed"):
        update(DOC.replace("peer speed", "peer other"), tmp_path, "doc.md")
    with pytest.raises(TableError, match="never closed"):
        update(DOC.replace("<!-- /bench-table -->\n", ""), tmp_path)
    with pytest.raises(TableError, match="without a start"):
        update(DOC.replace("<!-- bench-table: peer speed -->\n", ""), tmp_path)


def test_a_table_refuses_rows_of_the_wrong_width(tmp_path):
    with pytest.raises(ValueError, match="2 cells for 3 columns"):
        write(tmp_path, "peer", [["A", 1.0]])


def test_results_record_where_they_were_measured(tmp_path):
    write(tmp_path, "peer", [["A", 1.0, 1.0]])
    meta = json.loads((tmp_path / "peer.json").read_text())["meta"]
    assert meta["bench"] == "peer" and meta["command"] == "python3 bench/peer.py --x"
    assert meta["commit"] and meta["date"] and meta["machine"]["cores"]


def test_the_energy_benches_kernels_run_as_the_scene_does():
    # The CPU energy benches (derivatives, sympy_compare, simd_lanes) run
    # each case's kernels through benchlib.energy_cases: a change of the
    # runtime's launch once broke all three without a test noticing.
    from benchlib.energy_cases import CASES, check_agrees

    case = next(c for c in CASES if c.name == "mass-spring (6)")
    energy = case.build(case.instances(16))
    _, _, launches = energy.kernels(["grad", "hess"])
    for launch in launches:
        launch()
    # The "out" buffer of each launch; Hessians are symmetric, so their
    # column-major storage reads the same row-major.
    gradient, hessian = (launch.args[3][0].reshape(16, -1) for launch in launches)
    check_agrees(gradient, hessian.reshape(16, 6, 6), energy.derivatives())
