"""The built report (``hybobs report``): its links, images, alt texts, tables and figures (issue 17).

One report is built for the module -- the quick preview (``build_report(quick=True)``: every
section, table and figure of the full report from fewer samples, ``slow``) -- while every
``Figure.savefig`` is intercepted, so the axes of every figure are inspected as drawn: each has
data, its quantity and its unit (where the paper gives one), no ``"x 10"`` display scaling, and the
flags of the observer figure sit on their own labelled axes.  The fast tests below check the
checker itself and the figure functions on small inputs.
"""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from tests.check_links import alt_problem, check_html_tree, image_kind

# ---------------------------------------------------------------------------- axes records


def _image_shows_something(ax, im) -> bool:
    """Whether an image draws any pixel not of the axes' background (an all-white cut is empty)."""
    from matplotlib.colors import to_rgba

    arr = np.ma.masked_invalid(np.asarray(im.get_array(), dtype=float))
    if arr.count() == 0:
        return False
    colours = im.cmap(im.norm(np.unique(arr.compressed())))
    background = np.array(to_rgba(ax.get_facecolor()))
    return bool(np.any(np.abs(colours - background).max(axis=1) > 1e-6))


def has_data(ax) -> bool:
    """At least one artist with data: a non-empty line, collection, non-blank image or patch (not the frame)."""
    if any(len(line.get_xdata()) > 0 for line in ax.lines):
        return True
    for coll in ax.collections:
        if len(coll.get_paths()) or len(coll.get_offsets()):
            return True
    if any(_image_shows_something(ax, im) for im in ax.images):
        return True
    return any(p is not ax.patch for p in ax.patches)


def record_axes(fig) -> list[dict]:
    """What the tests need of each axes of ``fig``, read before it is saved."""
    fig.canvas.draw()  # tick labels exist only once drawn
    out = []
    for ax in fig.axes:
        shared_y = [o for o in ax.get_shared_y_axes().get_siblings(ax) if o is not ax]
        out.append({
            "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel(), "title": ax.get_title() or ax.get_title(loc="left"),
            "has_data": has_data(ax), "shares_y_with_labelled": any(o.get_ylabel() for o in shared_y),
            "xticklabels_visible": any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()),
            "yticklabels": [t.get_text() for t in ax.get_yticklabels() if t.get_text()],
            "bbox": tuple(ax.get_position().bounds), "is_twin": bool(ax.get_shared_x_axes().get_siblings(ax)) and any(
                o is not ax and tuple(o.get_position().bounds) == tuple(ax.get_position().bounds)
                for o in ax.get_shared_x_axes().get_siblings(ax)),
        })
    return out


@pytest.fixture(scope="module")
def built_report(tmp_path_factory):
    """The report (the quick preview: the full report's sections from fewer samples), built once,
    with the axes of every figure it saved."""
    from matplotlib.figure import Figure

    from hybobs_opt.report import build_report

    out = tmp_path_factory.mktemp("report")
    figures: dict[str, list[dict]] = {}
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        figures[Path(str(fname)).name] = record_axes(self)
        return original(self, fname, *args, **kwargs)

    Figure.savefig = savefig
    try:
        result = build_report(out, quick=True)
    finally:
        Figure.savefig = original
    assert result["quick"] is True
    assert all(s["ok"] for s in result["sections"]), [s["error"] for s in result["sections"] if not s["ok"]]
    return SimpleNamespace(dir=out, html=(out / "index.html").read_text(), figures=figures, result=result)


# ---------------------------------------------------------------------------- the report, built


@pytest.mark.slow
def test_report_links_images_and_alt_texts(built_report):
    assert check_html_tree(built_report.dir) == []
    listed = {f for s in built_report.result["sections"] for f in s["figures"]}
    shown = set(re.findall(r"<img src='([^']+)'", built_report.html))
    assert listed == shown and listed <= set(built_report.figures)


@pytest.mark.slow
def test_report_every_axes_has_data(built_report):
    empty = [(name, i, ax["ylabel"] or ax["title"]) for name, axes in built_report.figures.items()
             for i, ax in enumerate(axes) if not ax["has_data"]]
    assert empty == [], "\n".join(map(str, empty))
    # the Fig. 6(a) plane of the paper misses X*_5: its all-white cut is no longer drawn
    assert "regions_fig6a_paper_plane.png" not in built_report.figures
    assert "the plane does not meet X*_5" in built_report.html


#: Figure name (prefix) -> the example whose state units its axes must carry.
UNIT_FIGURES = {
    "example_": None,  # the example named in the file
    "regions_": "powertrain3", "observers_": "powertrain3", "lmi_observer_": None, "piston_comparison": "magnetic_piston",
    "driveline_fig6": "driveline", "drift_junction": "traffic_junction", "drift_server": "switching_server",
}


def _example_of(name: str) -> str | None:
    for prefix, ex in UNIT_FIGURES.items():
        if name.startswith(prefix):
            return ex or re.sub(r"^(example_|lmi_observer_)", "", name)[:-4]
    return None


@pytest.mark.slow
def test_report_axes_carry_quantity_and_unit(built_report):
    from hybobs_opt.studies import get_example

    units = {"theta_mc": "rad", "theta_cl": "rad", "omega_c": "rad/s", "omega_m": "rad/s", "omega_l": "rad/s", "theta": "rad"}
    problems = []
    for name, axes in built_report.figures.items():
        ex = _example_of(name)
        state_units = dict(units) if ex in ("powertrain3", "powertrain5") else {}
        if ex:
            e = get_example(ex)
            state_units.update({s: e.state_unit(s) for s in e.state_names if e.state_unit(s)})
        for i, ax in enumerate(axes):
            for which in ("xlabel", "ylabel"):
                label = ax[which]
                if re.search(r"\w\s+[x*]\s+\d+(\.\d+)?$", label):  # "theta x 10"
                    problems.append((name, i, which, label, "display scaling"))
                for state, unit in state_units.items():
                    if re.search(rf"(^|[\s|(]){re.escape(state)}($|[\s|)])", label) and f"[{unit}" not in label:
                        problems.append((name, i, which, label, f"no unit [{unit}]"))
            if not ax["ylabel"] and not ax["shares_y_with_labelled"]:
                problems.append((name, i, "ylabel", "", "no quantity"))
            if ax["xticklabels_visible"] and not ax["xlabel"] and not ax["is_twin"]:
                problems.append((name, i, "xlabel", "", "tick labels without a quantity"))
    assert problems == [], "\n".join(map(str, problems))
    # the cuts are unscaled, in rad and rad/s, as the issue asks
    assert built_report.figures["regions_fig3b.png"][0]["xlabel"] == "theta [rad]"
    assert built_report.figures["regions_fig3b.png"][0]["ylabel"] == "omega_m [rad/s]"


@pytest.mark.slow
def test_report_observer_flags_have_their_own_axes(built_report):
    for name in ("observers_fig7_9.png", "observers_noisy.png"):
        axes = built_report.figures[name]
        flags = [ax for ax in axes if ax["ylabel"] == "flag"]
        assert flags and all(set(ax["yticklabels"]) == {"not observable", "observable"} for ax in flags)
        errors = [ax for ax in axes if ax["ylabel"].startswith("|error")]
        assert {ax["title"] for ax in errors} >= {"lookup observer", "miqp observer"}
        # no flag axis lies over an error panel (the old figure drew the flags on a twin axis)
        for f in flags:
            assert not any(f["bbox"] == e["bbox"] for e in errors)
        assert not any(ax["is_twin"] for ax in axes)


@pytest.mark.slow
def test_report_noise_study_shows_each_observer_and_the_criterion(built_report):
    axes = built_report.figures["observers_noise_study.png"]
    titles = {ax["title"] for ax in axes}
    assert {"lookup observer", "lookup-noise observer", "kalman observer"} <= titles
    assert all(ax["ylabel"] == "error omega_l [rad/s]" and ax["has_data"] for ax in axes)
    study = next(s for s in built_report.result["sections"] if s["key"] == "observers")["summary"]["noise_study"]
    at = next(lv for lv in study["levels"] if lv["noise"] == 0.01)["observers"]
    # the criterion, checked on the report's own run
    assert at["lookup-noise"]["n_flagged_beyond_5_sigma"] == 0 and at["lookup-noise"]["flags"]["observable"] > 0
    assert "Noise-aware lookup observers against a Kalman filter" in built_report.html


@pytest.mark.slow
def test_report_radii_hold_the_true_states_and_are_drawn_above_the_errors(built_report):
    """The bounded-noise subsection: no true state outside any stated radius on the report's own run,
    the three observers flag the same steps (the lookup's outer box equals the exact one here), and
    the figure has one log-scale panel per state with a radius line and error dots per observer."""
    radii = next(s for s in built_report.result["sections"] if s["key"] == "observers")["summary"]["radii"]
    obs = radii["observers"]
    assert set(obs) == {"set_membership", "miqp_bounded", "lookup_bounded"}
    for name, r in obs.items():
        assert r["n_outside_radius"] == 0 and r["n_with_radius"] == radii["steps"] - 2, name
    assert obs["set_membership"]["flags"]["observable"] > 0
    assert len({r["flags"]["observable"] for r in obs.values()}) == 1
    axes = built_report.figures["observers_radii.png"]
    assert [ax["ylabel"] for ax in axes] == ["theta [rad]", "omega_m [rad/s]", "omega_l [rad/s]"]
    assert all(ax["has_data"] for ax in axes)
    assert "Certified radii under bounded noise" in built_report.html


@pytest.mark.slow
def test_report_colour_words_match_the_plots(built_report):
    from matplotlib.image import imread

    from hybobs_opt.report.plots import CUT_COLOURS

    section = built_report.html.split("<section id='regions'>")[1].split("</section>")[0]
    words = set(re.findall(r"\b(red|green|blue|magenta|white|black|grey|gray|orange|purple|yellow|pink)\b", section))
    assert words == {w for w, _ in CUT_COLOURS.values()}
    pixels = imread(built_report.dir / "regions_fig4b.png")[..., :3].reshape(-1, 3)
    for word, colour in CUT_COLOURS.values():
        rgb = np.array([int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
        assert np.any(np.abs(pixels - rgb).max(axis=1) < 2 / 255), (word, colour)
    observers = built_report.html.split("<section id='observers'>")[1].split("</section>")[0]
    assert "shaded green" in observers


class _TableParents(HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.bad, self.n = [], 0, 0

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.n += 1
            if not any(t == "div" and "table-wrap" in (dict(a).get("class") or "") for t, a in self.stack):
                self.bad += 1
        self.stack.append((tag, attrs))

    def handle_endtag(self, tag):
        while self.stack and self.stack.pop()[0] != tag:
            pass


@pytest.mark.slow
def test_report_tables_scroll_inside_the_page(built_report):
    p = _TableParents()
    p.feed(built_report.html)
    assert p.n >= 20 and p.bad == 0
    assert re.search(r"\.table-wrap\s*\{[^}]*overflow-x:\s*auto", built_report.html)


@pytest.mark.slow
def test_report_text_has_no_python_literals(built_report):
    """The page as read shows no True/False/None, numpy reprs, constant names of the code or
    floats at full precision (tests/check_report_text.py)."""
    from tests.check_report_text import literal_problems, visible_text

    problems = literal_problems(visible_text(built_report.html))
    assert problems == [], "\n".join(problems)


@pytest.mark.slow
def test_report_tables_are_wrapped_and_numeric_columns_name_a_unit(built_report):
    from tests.check_report_text import table_problems, tables_of

    problems = table_problems(built_report.html)
    assert problems == [], "\n".join(problems)
    assert len(tables_of(built_report.html)) >= 20


@pytest.mark.slow
def test_report_contents_sidebar_links_every_section(built_report):
    nav = re.search(r"<nav class=\"toc\"[^>]*>(.*?)</nav>", built_report.html, re.DOTALL).group(1)
    keys = [s["key"] for s in built_report.result["sections"]]
    linked = re.findall(r"href='#([^']+)'", nav)
    assert [k for k in linked if k in keys] == keys
    # the observers' subsections (noise study, unknown gap, radii) are listed under their section
    assert sum(1 for k in linked if k.startswith("observers-")) >= 4


@pytest.mark.slow
def test_report_numbers_come_from_the_run(built_report):
    # the timing table had a row read from the repository's benchmarks/results/regions.json
    assert "regions.json" not in built_report.html
    assert "benchmarks/results" not in built_report.html


@pytest.mark.slow
def test_quick_preview_says_so_and_states_its_sample_counts(built_report):
    """The preview's title says what it is, and its text states the sample counts it ran (the
    observer table's steps column and the prose agree with the run's summary)."""
    assert "quick preview" in built_report.html.split("</h1>")[0]
    obs = next(s for s in built_report.result["sections"] if s["key"] == "observers")["summary"]
    steps = obs["noise_free"]["steps"]
    assert steps < 3000 and f"{steps} samples" in built_report.html


def test_quick_is_validated_and_refused_with_a_system(tmp_path, capsys):
    from hybobs_opt.cli import main
    from hybobs_opt.errors import ModelError
    from hybobs_opt.report import build_report

    with pytest.raises(ModelError, match="quick"):
        build_report(tmp_path, quick="yes")
    assert main(["report", "powertrain3", "--quick", "--out-dir", str(tmp_path / "r")]) != 0
    assert "--quick" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


# ---------------------------------------------------------------------------- fast: the checker


def _png(path: Path) -> None:
    from hybobs_opt.plotting import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(1, 1))
    ax.plot([0, 1])
    fig.savefig(path)
    plt.close(fig)


def test_checker_finds_every_kind_of_problem(tmp_path):
    _png(tmp_path / "a.png")
    (tmp_path / "fake.png").write_text("not an image")
    (tmp_path / "other.html").write_text("<p id='here'>x</p>")
    (tmp_path / "index.html").write_text(
        "<h2 id='top'>t</h2>"
        "<a href='#top'>ok</a><a href='other.html#here'>ok</a><a href='https://example.org/x'>external</a>"
        "<a href='#nowhere'>bad anchor</a><a href='missing.html'>bad file</a><a href='other.html#gone'>bad anchor</a>"
        "<img src='a.png' alt='A line from (0, 0) to (1, 1)'>"
        "<img src='a.png' alt='a.png'><img src='a.png'><img src='a.png' alt=' '>"
        "<img src='missing.png' alt='something'><img src='fake.png' alt='something else'>"
        "<img src='a.png' alt='../_images/a.png'>"
    )
    problems = check_html_tree(tmp_path)
    text = "\n".join(problems)
    assert len(problems) == 9, text
    for needle in ("'#nowhere'", "'missing.html'", "'other.html#gone'", "'missing.png'", "'fake.png' is not a readable",
                   "file name ('a.png')", "no alt text", "an empty alt text", "file name ('../_images/a.png')"):
        assert needle in text


def test_checker_passes_a_good_page_and_fails_the_old_alt_texts(tmp_path):
    _png(tmp_path / "example_driveline.png")
    (tmp_path / "index.html").write_text(
        "<ul><li><a href='#examples'>Examples</a></li></ul><section id='examples'>"
        "<img src='example_driveline.png' alt='Simulation of the driveline: theta_e [rad] against time'></section>")
    assert check_html_tree(tmp_path) == []
    (tmp_path / "index.html").write_text("<img src='example_driveline.png' alt='example_driveline.png'>")
    assert len(check_html_tree(tmp_path)) == 1
    assert alt_problem("Fig. 6", "driveline_fig6.png") is None
    assert alt_problem("driveline_fig6", "driveline_fig6.png") is not None
    assert image_kind(tmp_path / "example_driveline.png") == "png"
    (tmp_path / "f.svg").write_text("<?xml version='1.0'?>\n<svg xmlns='http://www.w3.org/2000/svg'></svg>")
    assert image_kind(tmp_path / "f.svg") == "svg"


def test_checker_command_line(tmp_path, capsys):
    from tests.check_links import main

    _png(tmp_path / "a.png")
    (tmp_path / "index.html").write_text("<img src='a.png' alt='a.png'>")
    assert main([str(tmp_path)]) == 1
    assert "file name" in capsys.readouterr().out
    (tmp_path / "index.html").write_text("<img src='a.png' alt='A rising line'>")
    assert main([str(tmp_path)]) == 0


# ---------------------------------------------------------------------------- fast: the figure functions


def _axes_of(path_fn):
    """Run ``path_fn(path)`` with savefig intercepted; the recorded axes of the one figure it saves."""
    from matplotlib.figure import Figure

    seen = []
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        seen.append(record_axes(self))
        return original(self, fname, *args, **kwargs)

    Figure.savefig = savefig
    try:
        path_fn()
    finally:
        Figure.savefig = original
    assert len(seen) == 1
    return seen[0]


def test_plot_region_cut_unscaled_with_units_and_an_empty_cut_is_detected(tmp_path):
    from hybobs_opt.regions import Cut
    from hybobs_opt.report.plots import plot_region_cut

    labels = np.array([["observable", "unobservable", "infeasible"]] * 2)
    cut = Cut(("theta", "omega_m"), {"omega_l": 25.0}, np.array([-0.2, 0.0, 0.2]), np.array([0.0, 600.0]), labels)
    axes = _axes_of(lambda: plot_region_cut(cut, tmp_path / "c.png", units={"theta": "rad", "omega_m": "rad/s"}))
    assert (axes[0]["xlabel"], axes[0]["ylabel"]) == ("theta [rad]", "omega_m [rad/s]") and axes[0]["has_data"]
    blank = Cut(cut.axes, cut.fixed, cut.x_values, cut.y_values, np.full_like(labels, "infeasible"))
    assert not _axes_of(lambda: plot_region_cut(blank, tmp_path / "b.png"))[0]["has_data"]


def test_plot_trace_labels_states_with_their_units(tmp_path):
    from hybobs_opt.report import plot_trace
    from hybobs_opt.studies import get_example

    ex = get_example("powertrain3")
    trace = ex.simulate(t_final=0.05)
    axes = _axes_of(lambda: plot_trace(trace, tmp_path / "t.png", units=ex.state_units))
    assert [a["ylabel"] for a in axes] == ["theta [rad]", "omega_m [rad/s]", "omega_l [rad/s]", "location q"]
    user = _axes_of(lambda: plot_trace(trace, tmp_path / "u.png"))  # a user system: names only
    assert [a["ylabel"] for a in user][:3] == ["theta", "omega_m", "omega_l"]


def test_example_units_are_declared_for_the_physical_papers():
    from hybobs_opt.studies import get_example, list_examples

    for ex in list_examples():
        assert len(ex.to_dict()["state_units"]) == ex.n_states
    assert get_example("traffic_junction").state_label("x1") == "x1 [vehicles]"
    assert get_example("powertrain5").state_label("omega_c") == "omega_c [rad/s]"
    assert get_example("double_scroll").state_label("x1") == "x1"  # paper 001's examples are dimensionless


def test_observer_figure_of_model_17_names_and_flags(tmp_path):
    """plot_bench's figure on model (17)'s state names (``hybobs observe powertrain5 --plot``), synthetic runs."""
    from hybobs_opt.studies.paper002_powertrain.plots import plot_observer_errors

    t = np.arange(200) * 1e-3
    names = ("theta_mc", "theta_cl", "omega_m", "omega_c", "omega_l")
    x = np.column_stack([np.sin(t * k) for k in range(1, 6)])
    trace = SimpleNamespace(t=t, x=x, state_names=names)
    flags = np.where(t < 0.1, "observable", "unobservable")
    outs = {"lookup": SimpleNamespace(n_steps=200, x_hat=x + 1e-9, flags=flags),
            "miqp": SimpleNamespace(n_steps=50, x_hat=x[:50] + 1e-6, flags=flags[:50])}
    axes = _axes_of(lambda: plot_observer_errors(trace, outs, tmp_path / "o.png"))
    labels = [a["ylabel"] for a in axes]
    assert labels[:2] == ["theta_cl [rad]", "omega_l [rad/s]"]
    assert labels.count("flag") == 4 and "|error theta_cl| [rad]" in labels and "|error omega_l| [rad/s]" in labels
    assert all(a["has_data"] for a in axes) and not any(a["is_twin"] for a in axes)
    assert sum(1 for a in axes if a["xlabel"] == "t [s]") == 2  # one time axis label per column, at the bottom
