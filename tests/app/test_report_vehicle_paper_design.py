"""The report's section on paper 004's vehicle gains as published against the synthesised design."""

from hybobs_opt.studies.paper004_nonmonotonic.paper_design import PAPER_SINGLE, PAPER_SWITCHED, SYNTH_SINGLE, SYNTH_SWITCHED


def test_report_section_holds_the_four_observers(tmp_path):
    from hybobs_opt.report.lmi_section import vehicle_paper_design_section

    sec = vehicle_paper_design_section(tmp_path, lambda msg: None)
    for label in (PAPER_SWITCHED, PAPER_SINGLE, SYNTH_SWITCHED, SYNTH_SINGLE):
        assert f"<td>{label}</td>" in sec.body_html
    assert "42.1703" in sec.body_html and "-0.1039" in sec.body_html  # eqs. (61)-(62) as printed
    assert [o["label"] for o in sec.summary["observers"]] == [PAPER_SWITCHED, PAPER_SINGLE, SYNTH_SWITCHED, SYNTH_SINGLE]
    assert len(sec.summary["differences"]) == 3


def test_section_is_registered_after_the_lmi_section():
    from hybobs_opt.report.html import _load_builtin_sections
    from hybobs_opt.report.section import _SECTIONS

    _load_builtin_sections()
    keys = [k for k, _ in _SECTIONS]
    assert "lmi" in keys and keys.index("vehicle_paper_design") == keys.index("lmi") + 1
