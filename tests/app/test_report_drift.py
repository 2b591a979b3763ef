"""The report's section on the constant-drift observers of paper 003."""


def test_report_section_builds(tmp_path):
    from hybobs_opt.report.drift_section import drift_section

    sec = drift_section(tmp_path, lambda msg: None)
    assert (tmp_path / "drift_junction.png").read_bytes()[:4] == b"\x89PNG"
    cmp_ = sec.summary["comparison"]
    lookup = cmp_["traffic_junction"]["observers"]["lookup table (paper 002)"]
    assert lookup["applies"] and lookup["horizon_T"] == 4
    polling = cmp_["polling_server"]["observers"]
    assert polling["sequential deadbeat"]["min_estimate"] < 0.0 <= polling["positive LP"]["min_estimate"]
    assert all(rec["verified"] for rec in sec.summary["infeasible"])
