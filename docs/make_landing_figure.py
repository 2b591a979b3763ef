"""Draw the figure of the landing page (docs/index.rst): ``docs/figures/landing_lookup.png``.

The lookup-table deadbeat observer (Algorithm 4.1 of paper 002) on the shipped ``powertrain3``
example's scenario (model (16), gear ratio 1/12, horizon T = 3): the estimated twist angle against
the simulated one, with the samples the observer flags ``unobservable`` (the state is not
determined by the last T outputs; the observer predicts open loop) shaded.  Run it from the
repository root with ``MPLBACKEND=Agg python docs/make_landing_figure.py`` and commit the PNG; the
figure changes only when the observer or the example does.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybobs_opt import LookupObserver, analyse_observability, get_example  # noqa: E402

OUT = Path(__file__).resolve().parent / "figures" / "landing_lookup.png"


def main() -> None:
    example = get_example("powertrain3")
    trace = example.simulate()
    run = LookupObserver(analyse_observability(example.build(), 3)).run(trace.u, trace.y)
    fig, (ax, ax_mode) = plt.subplots(2, 1, figsize=(8, 4.2), sharex=True, height_ratios=(3, 1),
                                      layout="constrained")
    unobservable = np.asarray(run.flags) == "unobservable"
    for axis in (ax, ax_mode):
        axis.fill_between(trace.t, 0, 1, where=unobservable, transform=axis.get_xaxis_transform(),
                          color="0.88", step="mid", label="flagged unobservable (open-loop prediction)")
    ax.plot(trace.t, trace.x[:, 0], color="k", lw=2.2, label="true twist angle (simulation)")
    ax.plot(trace.t, run.x_hat[:, 0], color="tab:orange", lw=1.0, ls="--", label="lookup observer estimate")
    ax.set_ylabel(r"$\theta$ [rad]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("Lookup-table deadbeat observer (Algorithm 4.1, T = 3) on powertrain3", fontsize=10)
    ax_mode.step(trace.t, trace.q, where="post", color="k", lw=1.2, label="true mode")
    ax_mode.step(trace.t, run.mode, where="post", color="tab:orange", lw=0.8, ls="--", label="estimated mode")
    ax_mode.set_yticks([0, 1, 2], ["neg.", "backlash", "pos."])
    ax_mode.set_ylabel("mode")
    ax_mode.set_xlabel("time [s]")
    fig.savefig(OUT, dpi=110)
    print(OUT)


if __name__ == "__main__":
    main()
