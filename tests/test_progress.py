"""Progress: notes above the bars, a bar per stage whose total can be re-estimated, nothing when quiet."""
import io

from bayesbeam.progress import SILENT, Progress, as_progress


def test_a_stage_counts_its_work_and_shows_the_figures():
    out = io.StringIO()
    progress = Progress(file=out)
    with progress.stage("evidence (SMC)", 4, "run") as bar:
        bar.advance()
        bar.advance(2)
        bar.describe("max tau 12.0")
        assert bar.done == 3
    text = out.getvalue()
    assert "evidence (SMC)" in text and "3/4" in text and "max tau 12.0" in text


def test_retotal_never_goes_below_the_work_done():
    """An emcee bar's total is the steps the chain will likely need: it may shrink (early stop of
    SMC repeats) or grow (a longer autocorrelation time), never below what is done."""
    out = io.StringIO()
    with Progress(file=out).stage("sampling (emcee)", 1000, "step") as bar:
        bar.advance(250)
        bar.retotal(600)
        assert bar._bar.total == 600
        bar.retotal(100)
        assert bar._bar.total == 250
    assert "250/250" in out.getvalue()


def test_notes_print_and_quiet_prints_nothing():
    out = io.StringIO()
    Progress(file=out)("optimising 2 models")
    assert out.getvalue() == "  optimising 2 models\n"
    quiet = io.StringIO()
    progress = Progress(enabled=False, file=quiet)
    progress("a note")
    with progress.stage("optimising", 2) as bar:
        bar.advance(2)
    assert quiet.getvalue() == ""


def test_as_progress_takes_none_a_progress_or_a_line_callable():
    assert as_progress(None) is SILENT
    progress = Progress()
    assert as_progress(progress) is progress
    lines = []
    wrapped = as_progress(lines.append)
    wrapped("a line")
    with wrapped.stage("optimising", 2) as bar:      # a plain callable gets no bars
        bar.advance(2)
    assert lines == ["a line"]
