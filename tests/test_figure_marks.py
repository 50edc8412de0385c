"""What the figures show, read from the matplotlib objects: the loop-gain Bode plot marks the
gain crossover, the phase and gain margins, the 0 dB and -180° lines (as python-control's
``bode_plot(display_margins=True)``); every axis has its unit, every colour a legend entry,
every title fits. The margins pelcs computes agree with python-control's ``margin()`` on the
same frequency response and with closed forms."""

from __future__ import annotations

from pathlib import Path

import control
import numpy as np
import pytest
from matplotlib.colors import to_hex

from lcs.analysis.basins import cell_basins
from lcs.analysis.maps import FunctionMap
from lcs.smallsignal.response import FrequencyResponse, loop_margins
from pelcs.analysis_plots import plot_basins
from pelcs.commands.ac import bode_figure

AC = Path(__file__).resolve().parents[1] / "converters" / "netlists" / "ac"

# T(s) = K / (s (1 + s/w1) (1 + s/w2)): phase -180° at w = sqrt(w1 w2), where
# |T| = K / (w1 + w2) (so the gain margin is 20 log10((w1 + w2) / K) dB).
K, W1, W2 = 2.0e4, 2 * np.pi * 2e3, 2 * np.pi * 20e3


def _third_order(freq):
    s = 2j * np.pi * freq
    return K / (s * (1 + s / W1) * (1 + s / W2))


def _loop_response(freq, loop):
    return FrequencyResponse(freq, ("T",), loop[:, None], "Vinj", "exact", 1e-5)


def _drawn(fig):
    """Draw ``fig`` (as saving does) and return its renderer."""
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _title_fits(fig, ax) -> bool:
    renderer = _drawn(fig)
    box = ax.title.get_window_extent(renderer)
    return (box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height
            and box.width <= ax.get_window_extent(renderer).width)


def _legend_colours(ax) -> set[str]:
    handles = ax.get_legend().legend_handles
    colours = set()
    for h in handles:
        get = getattr(h, "get_color", None) or h.get_facecolor
        colours.add(to_hex(get()))
    return colours


def test_closed_form_margins():
    freq = np.logspace(1, 6, 400)
    m = loop_margins(freq, _third_order(freq))
    f180 = np.sqrt(W1 * W2) / (2 * np.pi)
    assert m.phase_crossover == pytest.approx(f180, rel=1e-3)
    assert m.gain_margin == pytest.approx(20 * np.log10((W1 + W2) / K), abs=0.01)
    wc = 2 * np.pi * m.crossover
    assert abs(_third_order(np.array([m.crossover]))[0]) == pytest.approx(1.0, rel=1e-3)
    exact_pm = 180 - 90 - np.degrees(np.arctan(wc / W1) + np.arctan(wc / W2))
    assert m.phase_margin == pytest.approx(exact_pm, abs=0.05)


def _python_control_margins(fr):
    gm, pm, wpc, wgc = control.margin(fr.to_frd()["T", fr.inject])
    return 20 * np.log10(gm), pm, wpc / (2 * np.pi), wgc / (2 * np.pi)


def test_margins_agree_with_python_control_synthetic():
    freq = np.logspace(1, 6, 200)
    fr = _loop_response(freq, _third_order(freq))
    m = loop_margins(freq, fr["T"])
    gm, pm, fpc, fgc = _python_control_margins(fr)
    assert m.crossover == pytest.approx(fgc, rel=2e-3)
    assert m.phase_margin == pytest.approx(pm, abs=0.2)
    assert m.phase_crossover == pytest.approx(fpc, rel=2e-3)
    assert m.gain_margin == pytest.approx(gm, abs=0.05)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_margins_agree_with_python_control_on_a_converter_loop():
    from pelcs.api import ac

    fr = ac(AC / "buck_pi_loop.cir", period="ts", loop="Vinj",
            freq=np.logspace(1, np.log10(2e4), 80))
    _, pm, _, fgc = _python_control_margins(fr)
    assert fr.margins.crossover == pytest.approx(fgc, rel=5e-3)
    assert fr.margins.phase_margin == pytest.approx(pm, abs=0.3)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_loop_gain_plot_marks_margins_units_and_legend():
    freq = np.logspace(1, 6, 120)
    fr = _loop_response(freq, _third_order(freq))
    m = loop_margins(freq, fr["T"])
    fig = bode_figure(fr, m, "a_converter_with_a_rather_long_file_name_for_its_netlist.cir")
    ax1, ax2 = fig.axes
    assert ax1.get_ylabel() == "magnitude (dB)" and ax2.get_ylabel() == "phase (deg)"
    assert ax2.get_xlabel() == "frequency (Hz)"
    labels1 = ax1.get_legend_handles_labels()[1]
    labels2 = ax2.get_legend_handles_labels()[1]
    assert "0 dB" in labels1 and "-180°" in labels2
    assert f"gain crossover {m.crossover:.4g} Hz" in labels1
    assert f"phase margin {m.phase_margin:.1f}°" in labels2
    assert f"gain margin {m.gain_margin:.1f} dB" in labels1
    # the margin segments: -180° to the phase at the crossover, 0 dB down to -GM
    pm_line = next(li for li in ax2.lines if li.get_label().startswith("phase margin"))
    assert pm_line.get_ydata()[0] == pytest.approx(-180.0)
    assert np.diff(pm_line.get_ydata())[0] == pytest.approx(m.phase_margin)
    gm_line = next(li for li in ax1.lines if li.get_label().startswith("gain margin"))
    assert list(gm_line.get_ydata()) == pytest.approx([0.0, -m.gain_margin])
    assert gm_line.get_xdata()[0] == pytest.approx(m.phase_crossover)
    # every colour drawn is in the legend
    for ax in (ax1, ax2):
        drawn = {to_hex(li.get_color()) for li in ax.lines} | {
            to_hex(c.get_color()) for c in ax.collections}
        assert drawn <= _legend_colours(ax)
    assert "loop gain T at Vinj" in " ".join(ax1.get_title().split())
    assert _title_fits(fig, ax1)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_response_plot_title_and_legend():
    freq = np.logspace(1, 4, 20)
    fr = FrequencyResponse(freq, ("v(out)",), _third_order(freq)[:, None], "Vc", "exact",
                           1e-5)
    fig = bode_figure(fr, None, "buck.cir")
    ax1, ax2 = fig.axes
    assert ax1.get_title() == "buck.cir: response to Vc (exact)"
    assert ax1.get_legend() is not None and ax2.get_legend() is not None
    assert _title_fits(fig, ax1)


def _two_wells(v):
    x, y = v
    if abs(x) > 2:
        return np.array([3 * x, 0.4 * y])
    s = 1.0 if x > 0 else -1.0
    return np.array([s + 0.4 * (x - s), 0.4 * y])


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_basins_plot_has_a_legend_per_colour_and_titles_that_fit(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    figures = []
    save = Figure.savefig

    def capture(self, *args, **kwargs):
        figures.append(self)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", capture)
    m = FunctionMap(_two_wells, ("v(C1)", "i(L1)"))
    bm = cell_basins(m, [("v(C1)", -3.05, 3.05, 61), ("i(L1)", -1.05, 1.05, 21)], workers=1)
    long_title = ("basins: Voltage-mode controlled buck converter (Deane and Hamill chaotic "
                  "buck), the textbook example of period doubling")
    plot_basins(bm, tmp_path / "b.png", title=long_title)
    fig = figures[-1]
    ax1, ax2 = fig.axes[:2]
    labels = ax1.get_legend_handles_labels()[1] + [
        t.get_text() for t in ax1.get_legend().get_texts()]
    assert "leaves the grid" in labels and "attractor cells" in labels
    assert sum(label.startswith("basin of attractor") for label in labels) == 2
    # each colour of the basins image is in the legend
    image_colours = {to_hex(c) for c in ax1.images[0].cmap.colors}
    assert image_colours <= _legend_colours(ax1)
    assert ax1.get_xlabel() == "i(L1) [A]" and ax1.get_ylabel() == "v(C1) [V]"
    assert fig.axes[2].get_ylabel() == "periods to reach the attractor"  # the colour bar
    assert " ".join(ax1.get_title().split()) == long_title  # wrapped, not cut
    for ax in (ax1, ax2):
        assert _title_fits(fig, ax)


def _drawn_colours(ax) -> set[str]:
    """The colours of the lines and scatters of ``ax`` that carry data (not the grid)."""
    colours = {to_hex(line.get_color()) for line in ax.get_lines() if line.get_label()
               and not line.get_label().startswith("_")}
    for c in ax.collections:
        colours |= {to_hex(f) for f in c.get_facecolor()}
    return colours


def test_bifurcation_figure_has_units_a_title_and_a_legend_per_direction():
    from lcs.analysis.bifurcation import BifurcationDiagram, SweepBranch
    from pelcs.analysis_plots import bifurcation_figure

    values = np.array([1.0, 2.0, 3.0])
    branches = [SweepBranch(d, values, np.random.default_rng(0).random((3, 4, 2)),
                            np.zeros((3, 2)), np.ones(3, dtype=bool)) for d in ("up", "down")]
    d = BifurcationDiagram("vin", ("v(out)", "i(L1)"), ("v(out)", "i(L1)"), 10, 4, True,
                           branches)
    fig = bifurcation_figure(d)
    ax1, ax2 = fig.axes
    assert ax1.get_ylabel() == "v(out) [V]" and ax2.get_ylabel() == "i(L1) [A]"
    assert ax2.get_xlabel() == "vin"
    assert ax1.get_title() == "v(out), i(L1) sampled once a period against vin"
    assert [t.get_text() for t in ax1.get_legend().get_texts()] == ["up", "down"]
    for ax in (ax1, ax2):
        assert _drawn_colours(ax) <= _legend_colours(ax1) and len(_drawn_colours(ax)) == 2
    assert bifurcation_figure(d, title="t").axes[0].get_title() == "t"


def test_sweep_figure_has_units_a_title_and_a_legend_per_line():
    from lcs.analysis.tables import SweepTable
    from pelcs.sweep_plots import sweep_figure

    grid = np.array([(vin, r) for r in (10.0, 20.0) for vin in (5.0, 10.0, 15.0)])
    table = SweepTable(inputs=("vin", "R1"), input_values=grid, measures=("mean(v(out))",),
                       values=grid[:, :1] / 2, ok=np.ones(6, dtype=bool), messages=[""] * 6,
                       swept=("vin", "R1"), units={"vin": "V", "R1": "Ω",
                                                   "mean(v(out))": "V"})
    fig = sweep_figure(table)
    (ax,) = fig.axes
    assert ax.get_xlabel() == "vin (V)" and ax.get_ylabel() == "mean(v(out)) (V)"
    assert ax.get_title() == "sweep of vin, R1"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["R1 = 10", "R1 = 20"]
    assert _drawn_colours(ax) <= _legend_colours(ax) and len(_drawn_colours(ax)) == 2
