"""Pictures of the user guide *Trajectory*: [K95]'s Fig. 1 and Fig. 2 (gains of the fuzzy and
Kalman filters) and a change detected on a simulated trajectory.

Run: ``python docs/scripts/trajectory_figures.py`` (needs matplotlib); writes
``docs/images/trajectory_gains_fig1.png``, ``trajectory_gains_fig2.png`` and
``trajectory_change_points.png``.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import kalmanfield as kf  # noqa: E402
from kalmanfield.trajectory import plot_change_points, plot_gain_comparison  # noqa: E402

IMAGES = Path(__file__).resolve().parent.parent / "images"


def main() -> None:
    IMAGES.mkdir(exist_ok=True)
    for figure in (1, 2):
        fig = plot_gain_comparison(figure, n=15)
        fig.savefig(IMAGES / f"trajectory_gains_fig{figure}.png", dpi=80)
        plt.close(fig)

    rng = np.random.default_rng(7)
    t = np.arange(200.0)
    truth = np.where(t < 120, 0.3 * t, 0.3 * 120 - 0.2 * (t - 120))  # a velocity jump at 120
    truth[60:] += 6.0  # and a position jump at 60
    z = truth + rng.normal(0, 1.0, t.size)
    found = kf.ChangeDetector(kf.FuzzyFilter(P=2.0, Q=0.05, R=1.0, P_vel=0.5, Q_vel=0.002)).run(z)
    fig, ax = plt.subplots(figsize=(7, 3))
    plot_change_points(z, found, ax=ax)
    ax.plot(t, truth, "--", color="0.2", lw=0.8, label="truth")
    ax.legend(fontsize=8)
    ax.set_title(f"cusum alarms at samples {[int(i) for i in found.indices()]}", fontsize=9)
    fig.tight_layout()
    fig.savefig(IMAGES / "trajectory_change_points.png", dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    main()
