"""``pelcs ac FILE``: small-signal frequency response of the switching converter.

::

    pelcs ac FILE [--period T] (--inject SOURCE | --loop NAME) --probe EXPR...
             [--freq FMIN:FMAX[:N]] [--param NAME=VALUE]... [--method exact|sweep]
             [--amplitude A] [--settle T] [--cycles K] [--step H] [--theta TH] [--json]
             [-o OUT.csv] [--plot OUT.png] [--averaged TOPOLOGY:NAME=VALUE,...]

The periodic steady state (period T) is found by Newton shooting; the independent source
``--inject`` is perturbed at each frequency (default: 30 points, log-spaced from fs/1000 to
fs/2) and the probes' components at that frequency are reported. ``--method exact`` (default)
linearises the exact orbit, every switching instant moving with the perturbation (saltation);
``--method sweep`` perturbs the source by a sinusoid in the time domain and measures, as a
PLECS AC sweep does. ``--loop NAME``: loop gain ``T = -v(n-)/v(n+)`` by Middlebrook voltage
injection at the zero-volt source NAME (positive node facing the controller), with crossover,
phase and gain margins.

``--json`` prints ``{"freq": [...], "probes": {"v(out)": {"mag_db": [...], "phase_deg": [...],
"re": [...], "im": [...]}}, "orbit": {...}, "loop": {...}}`` as strict JSON: NaN and infinities
are null (a probe that does not respond at all, |H| = 0, has ``mag_db`` null where the text
table prints -inf); ``-o`` writes the responses as CSV
(``freq,<probe>_mag_db,<probe>_phase_deg,...``); ``--plot`` a Bode plot (magnitude in dB, phase
in degrees, fs/2 marked), with ``--averaged`` the CCM averaged model overlaid
(:func:`converters.averaged.small_signal_model`, e.g. ``buck:vin=12,d=0.5,r=1,l=100u,c=100u,
gain=1`` with ``gain`` the duty per unit of the injected source, ``input=vin`` for
line-to-output; probes named like its states, ``v(out)`` as the output capacitor voltage).

Exit status: 0 success; 2 input errors, and the cases where there is no response to compute
(said with the reason: a self-oscillating converter with the exact method, a sweep around an
unstable orbit; docs/smallsignal.md); 3 the steady state or a run failed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from pelcs.figures import fit_title, save_figure
from pelcs.jsonout import dumps
from pelcs.outputs import write_outputs
from pelcs.writers import write_table

from . import options
from .orbit import EXIT_FAILED, usage_error


def register(subparsers) -> None:
    """Add the ``ac`` subcommand."""
    p = subparsers.add_parser(
        "ac", help="small-signal frequency response (Bode plot, loop gain)",
        description="Frequency response of probes to a small perturbation of a source, "
        "around the periodic steady state of the switching converter.",
        epilog="example: pelcs ac buck_vc.cir --period ts --inject Vc --probe 'v(out)' "
        "--freq 100:50k:40 --plot bode.png")
    p.add_argument("file", help="netlist file")
    options.add_period(p,
                   help="switching period: seconds with SPICE suffix (10u) or a .param name "
                   "(default: the period the netlist defines, at a switch's control, in a "
                   "latched switch's clock or a PWM ramp; the notes name it)")
    p.add_argument("--inject", metavar="SOURCE", help="independent source to perturb")
    p.add_argument("--loop", metavar="NAME",
                   help="zero-volt source in the feedback path (positive node facing the "
                   "controller): loop gain and margins")
    options.add_probe(p, help="probe, e.g. 'v(out)' (repeatable or comma-separated)")
    p.add_argument("--freq", metavar="FMIN:FMAX[:N]",
                   help="N log-spaced frequencies, Hz (default N = 30), or one frequency F "
                   "(default: 30 from fs/1000 to fs/2); the API's freq=")
    options.add_param(p, help="override a global .param (repeatable)")
    options.add_method(p, ("exact", "sweep"), "exact",
                   help="exact: linearised exact orbit (default); sweep: time-domain "
                   "sinusoidal perturbation")
    p.add_argument("--amplitude", metavar="A",
                   help="perturbation amplitude in the source's unit (default 1 %% of its "
                   "value, 1 mV or 1 mA for a zero source)")
    p.add_argument("--settle", metavar="T",
                   help="sweep: settling time before each measurement (default: until the "
                   "slowest multiplier of the orbit has decayed to 1e-4, and 2 excitation "
                   "periods)")
    p.add_argument("--cycles", metavar="K", default="3",
                   help="excitation periods measured per frequency (default 3)")
    options.add_step(p)
    options.add_theta(p, default="0.5", help="Moreau θ (default 0.5)")
    options.add_json(p,
                   help="print the result as JSON (NaN and infinities as null, e.g. the "
                   "-inf dB of a zero response)")
    options.add_output(p, "OUT.csv", help="write the response as CSV")
    p.add_argument("--plot", metavar="OUT.png", help="Bode plot")
    p.add_argument("--averaged", metavar="TOPOLOGY:NAME=VALUE,...",
                   help="overlay the CCM averaged model on the plot, e.g. "
                   "buck:vin=12,d=0.5,r=1,l=100u,c=100u,gain=1")
    p.set_defaults(func=run)


def _freqs(text: str | None):
    """``FMIN:FMAX[:N]`` -> N log-spaced frequencies (Hz), or a single ``F``; None: the
    default."""
    from netlist.studies.ac import parse_frequencies

    return parse_frequencies(text) if text else None


_AVERAGED_KEYS = {"vin": "vin", "d": "duty", "r": "rload", "l": "lind", "c": "cout",
                  "l1": "l1", "c1": "c1", "l2": "l2", "c2": "c2", "gain": "gain",
                  "input": "input"}


def _averaged(spec: str | None):
    """``TOPOLOGY:NAME=VALUE,...`` -> (python-control model, gain, input name) or None."""
    from netlist.studies.sweep import parse_value

    if not spec:
        return None
    topo, _, rest = spec.partition(":")
    kw: dict = {}
    for item in filter(None, (v.strip() for v in rest.split(","))):
        name, eq, val = item.partition("=")
        key = _AVERAGED_KEYS.get(name.strip().lower())
        if not eq or key is None:
            raise usage_error("ac", f"--averaged: cannot read {item!r}",
                              "use TOPOLOGY:vin=..,d=..,r=..,l=..,c=..[,gain=..][,input=d|vin]")
        kw[key] = val.strip() if key == "input" else parse_value(val.strip(), "--averaged")
    gain = float(kw.pop("gain", 1.0))
    inp = str(kw.pop("input", "d")).lower()
    missing = [k for k in ("vin", "duty", "rload") if k not in kw]
    if missing or inp not in ("d", "vin"):
        raise usage_error("ac", f"--averaged {spec}: need vin, d, r (and the elements), "
                          "input d or vin")
    from converters.averaged import small_signal_model

    try:
        model = small_signal_model(topo.strip().lower(), kw.pop("vin"), kw.pop("duty"),
                                   kw.pop("rload"), **kw)
    except (TypeError, ValueError) as exc:
        raise usage_error("ac", f"--averaged {spec}: {exc}") from None
    return model, gain, inp


def run(args: argparse.Namespace) -> int:
    from netlist.parser import parse_file, parse_overrides
    from netlist.studies.ac import ac_analysis
    from netlist.studies.sweep import parse_value

    if not args.inject and not args.loop:
        raise usage_error("ac", "nothing to perturb", "pass --inject SOURCE or --loop NAME")
    from .simulate import split_probes

    probes = split_probes(args.probe)  # (v(a,b) is one probe)
    if not probes and not args.loop:
        raise usage_error("ac", "no probe", "pass --probe, e.g. --probe 'v(out)'")
    circuit = parse_file(args.file, params=parse_overrides(args.param) or None)
    period: float | str | None = args.period  # None: the netlist's (ac_analysis finds it)
    if period is not None:
        try:
            period = parse_value(args.period, "--period")
        except Exception:  # noqa: BLE001 (a .param name, resolved by the analysis)
            pass
    cycles = int(parse_value(args.cycles, "--cycles"))
    if cycles < 1:
        raise usage_error("ac", f"--cycles {args.cycles}: at least 1")
    averaged = _averaged(args.averaged)
    try:
        fr = ac_analysis(
            circuit, period=period, inject=args.inject, probes=probes,
            freqs=_freqs(args.freq), method=args.method,
            amplitude=parse_value(args.amplitude, "--amplitude") if args.amplitude else None,
            step=parse_value(args.step, "--step") if args.step else None,
            theta=parse_value(args.theta, "--theta"), cycles=cycles,
            settle=parse_value(args.settle, "--settle") if args.settle else None,
            loop=args.loop)
    except Exception as exc:  # noqa: BLE001
        from lcs.analysis.exact_orbit import PwlOrbitError
        from lcs.analysis.maps import MapError
        from lcs.results import SimulationError

        if isinstance(exc, (MapError, SimulationError, PwlOrbitError)):
            print(f"{args.file}: error: no periodic steady state to linearise: {exc}\n"
                  f"  hint: `pelcs orbit {args.file}` (with --order 2, ...) shows the steady "
                  "state: a period-doubled or chaotic converter has no period-1 orbit; pass "
                  "--period T if the netlist's period is not the switching period",
                  file=sys.stderr)
            return EXIT_FAILED
        raise
    margins = fr.margins
    data = fr.to_dict()
    out = Path(args.output) if args.output else None
    plot = Path(args.plot) if args.plot else None
    written = write_outputs("ac", [(out, lambda p: _write_csv(p, fr)),
                                   (plot, lambda p: _plot(p, fr, margins, args.file,
                                                                   averaged))])
    if args.json:
        print(dumps(data))
        return written.exit_status()
    print(f"{args.file}: response to {fr.inject} ({fr.method}), fs = {1 / fr.period:.6g} Hz")
    for note in fr.notes:
        print(f"  {note}")
    header = "freq (Hz)   " + "  ".join(f"{p + ' dB':>14s} {'deg':>8s}" for p in fr.probes)
    print(header)
    for i, f in enumerate(fr.freq):
        row = "  ".join(f"{fr.mag_db(p)[i]:14.3f} {fr.phase_deg(p)[i]:8.2f}" for p in fr.probes)
        print(f"{f:<11.5g} {row}")
    if margins is not None:
        pm = "n/a" if margins.phase_margin is None else f"{margins.phase_margin:.1f} deg"
        fc = "n/a" if margins.crossover is None else f"{margins.crossover:.5g} Hz"
        gm = "n/a" if margins.gain_margin is None else f"{margins.gain_margin:.1f} dB"
        print(f"loop gain: crossover {fc}, phase margin {pm}, gain margin {gm}")
    for path in written:
        print(f"wrote {path}")
    return written.exit_status()


def _write_csv(path: Path, fr) -> None:
    """``freq`` (Hz), then per probe its magnitude (dB) and phase (degrees), 9 digits."""
    columns = {"freq": np.asarray(fr.freq, dtype=float)}
    for p in fr.probes:
        columns[f"{p}_mag_db"] = np.asarray(fr.mag_db(p), dtype=float)
        columns[f"{p}_phase_deg"] = np.asarray(fr.phase_deg(p), dtype=float)
    write_table(path, columns, digits=9, format=".csv")


def _averaged_curve(averaged, probe: str, freq):
    """The averaged model's response of ``probe`` (None if it has no such state)."""
    model, gain, inp = averaged
    names = [s.lower() for s in model.output_labels]
    p = probe.lower()
    if p not in names:
        if p == "v(out)":
            p = names[-1]
        else:
            return None
    H = model(2j * np.pi * np.asarray(freq))  # (outputs, inputs, F)
    return H[names.index(p), 0 if inp == "d" else 1, :] * (gain if inp == "d" else 1.0)


def _plot(path: Path, fr, margins, title: str, averaged=None) -> None:
    save_figure(bode_figure(fr, margins, title, averaged), path, dpi=110)


def bode_figure(fr, margins, title: str, averaged=None):
    """The Bode plot of a :class:`~lcs.smallsignal.FrequencyResponse` (a matplotlib
    ``Figure``): magnitude (dB) and phase (degrees) against frequency (Hz), fs/2 marked, with
    ``margins`` (a loop gain, probe ``"T"``) the margins marked, with ``averaged`` the
    averaged model overlaid; ``title`` is the netlist's file name."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 6))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for p in fr.probes:
        line, = ax1.semilogx(fr.freq, fr.mag_db(p), marker=".", label=f"{p} ({fr.method})")
        ax2.semilogx(fr.freq, fr.phase_deg(p), marker=".", color=line.get_color(),
                     label=f"{p} ({fr.method})")
        if averaged is not None:
            ff = np.logspace(np.log10(fr.freq[0]), np.log10(fr.freq[-1]), 400)
            Ha = _averaged_curve(averaged, p, ff)
            if Ha is not None:
                ph = np.degrees(np.unwrap(np.angle(Ha)))
                # Same branch of the phase as the measured curve at the first point.
                ph += 360.0 * np.round((fr.phase_deg(p)[0] - ph[0]) / 360.0)
                ax1.semilogx(ff, 20 * np.log10(np.abs(Ha)), ls="--", color=line.get_color(),
                             label=f"{p} (averaged)")
                ax2.semilogx(ff, ph, ls="--", color=line.get_color(), label=f"{p} (averaged)")
    for ax in (ax1, ax2):
        ax.axvline(0.5 / fr.period, color="grey", ls="--", lw=0.8, label="fs/2")
        ax.grid(True, which="both", alpha=0.3)
    if margins is not None:
        _mark_margins(ax1, ax2, fr.freq, fr.phase_deg("T"), margins)
    ax1.set_ylabel("magnitude (dB)")
    ax2.set_ylabel("phase (deg)")
    ax2.set_xlabel("frequency (Hz)")
    what = (f"loop gain T at {fr.inject}" if margins is not None
            else f"response to {fr.inject}")
    fit_title(ax1, f"{Path(title).name}: {what} ({fr.method})")
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _mark_margins(ax1, ax2, freq: np.ndarray, phase: np.ndarray, margins) -> None:
    """The 0 dB and -180° lines, the gain crossover, and the phase and gain margins drawn as
    python-control's ``bode_plot(display_margins=True)`` draws them: the phase margin as a
    segment from the -180° line to the phase at the crossover, the gain margin as a segment
    from 0 dB down to the gain at the phase crossover. Each mark is in the legend with its
    value."""
    ax1.axhline(0.0, color="black", lw=0.8, label="0 dB")
    # The -180° line on the branch (mod 360°) that the plotted phase reaches or comes nearest.
    turns = np.round((np.asarray(phase) + 180.0) / 360.0)
    for k, level in enumerate(sorted({-180.0 + 360.0 * t for t in turns})):
        ax2.axhline(level, color="black", lw=0.8, label="-180°" if k == 0 else None)
    if margins.crossover is not None:
        fc = margins.crossover
        for ax in (ax1, ax2):
            ax.axvline(fc, color="tab:red", ls=":", lw=0.9,
                       label=f"gain crossover {fc:.4g} Hz" if ax is ax1 else None)
        # the phase at fc on the plotted branch: log-linear interpolation, as the margins
        ph_c = float(np.interp(np.log10(fc), np.log10(freq), phase))
        base = ph_c - margins.phase_margin
        ax2.plot([fc, fc], [base, ph_c], color="tab:red", lw=2.5,
                 label=f"phase margin {margins.phase_margin:.1f}°")
    if margins.phase_crossover is not None and margins.gain_margin is not None:
        fp = margins.phase_crossover
        ax2.axvline(fp, color="tab:purple", ls=":", lw=0.9,
                    label=f"phase crossover {fp:.4g} Hz")
        ax1.plot([fp, fp], [0.0, -margins.gain_margin], color="tab:purple", lw=2.5,
                 label=f"gain margin {margins.gain_margin:.1f} dB")
