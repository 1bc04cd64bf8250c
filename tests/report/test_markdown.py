"""Generated markdown blocks: the body between a block's markers is replaced and nothing else;
missing, repeated or swapped markers are refused with the file and the fix named. Exact string
equality throughout: the renderer's output is text, there is nothing to round."""
import pytest

from bayesbeam.report.markdown import (
    block_names,
    markdown_table,
    median_and_interval,
    read_block,
    replace_block,
    significant,
    write_blocks,
)

DOC = "# Title\n\nProse above.\n\n<!-- begin: t -->\nold\n<!-- end: t -->\n\nProse below.\n"


def test_replace_block_changes_only_the_body():
    new = replace_block(DOC, "t", "| a |\n|---|\n")
    assert new == "# Title\n\nProse above.\n\n<!-- begin: t -->\n| a |\n|---|\n<!-- end: t -->\n\nProse below.\n"
    assert read_block(new, "t") == "| a |\n|---|"
    assert replace_block(new, "t", "old") == DOC          # round trip: nothing else was touched


@pytest.mark.parametrize("text, fragment", [
    ("no markers\n", "no <!-- begin: t --> and <!-- end: t --> line"),
    ("<!-- begin: t -->\nx\n", "no <!-- end: t --> line"),
    ("<!-- end: t -->\n<!-- begin: t -->\n", "comes before"),
    (DOC + DOC, "marked more than once"),
    ("text <!-- begin: t --> inline\n<!-- end: t -->\n", "no <!-- begin: t --> line"),   # a marker is a whole line
])
def test_bad_markers_are_refused_naming_the_file_and_the_fix(text, fragment):
    with pytest.raises(ValueError, match="README.md") as error:
        replace_block(text, "t", "body", "README.md")
    assert fragment in str(error.value)


def test_write_blocks_rewrites_only_a_changed_file(tmp_path):
    path = tmp_path / "README.md"
    path.write_text(DOC)
    before = path.stat().st_mtime_ns
    write_blocks(path, {"t": "old"})
    assert path.stat().st_mtime_ns == before and path.read_text() == DOC
    write_blocks(path, {"t": "new"})
    assert read_block(path.read_text(), "t") == "new" and block_names(path.read_text()) == ["t"]


def test_table_and_number_formats():
    assert markdown_table(["a", "b"], [["1", "2"]]) == "| a | b |\n|---|---|\n| 1 | 2 |"
    with pytest.raises(ValueError, match="1 cells, the header 2"):
        markdown_table(["a", "b"], [["1"]])
    assert [significant(v, 3) for v in (1000.0, 873.2, 0.00134, 1.2e7, 3.4e-5)] == \
        ["1000", "873", "0.00134", "1.2e+07", "3.4e-05"]
    # width 0.0004 on 44.28: five decades -> 8 significant digits resolve it
    assert median_and_interval({"q05": 44.2798, "q50": 44.28, "q95": 44.2802}) == "44.28 [44.2798, 44.2802]"
