"""Design helpers: component values of the basic PWM converters from specifications.

All formulas are the ideal-switch steady-state relations of R. W. Erickson and D. Maksimović,
*Fundamentals of Power Electronics*, 2nd ed., Springer 2001: chapter 2 (inductor volt-second
and capacitor charge balance, small-ripple approximation, ripple formulas) and chapter 5
(discontinuous conduction mode: K = 2L/(R Ts), K_crit(D), and the DCM conversion ratios of
table 5.2). Ripples are peak-to-peak. Units: V, A, Ω, H, F, Hz, s.

| converter | M(D) in CCM | K_crit(D) | M in DCM |
|---|---|---|---|
| buck | D | 1 - D | 2 / (1 + sqrt(1 + 4K/D²)) |
| boost | 1/(1-D) | D(1-D)² | (1 + sqrt(1 + 4D²/K)) / 2 |
| buck-boost | -D/(1-D) | (1-D)² | -D/sqrt(K) |
| Čuk | -D/(1-D) | (1-D)² with L = L1 L2/(L1+L2) | -D/sqrt(K) |

The converter is in CCM when K > K_crit(D) (Erickson eq. 5.21).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

TOPOLOGIES = ("buck", "boost", "buck-boost", "cuk")


@dataclass(frozen=True)
class ConverterDesign:
    """Component values and the expected operating point of a designed converter.

    Attributes
    ----------
    topology : str
        ``"buck"``, ``"boost"``, ``"buck-boost"`` or ``"cuk"``.
    vin, vout : float
        Input and requested output voltage, V (vout < 0 for the inverting converters).
    R : float
        Load resistance, Ω.
    fs : float
        Switching frequency, Hz.
    duty : float
        CCM duty cycle D in (0, 1).
    L, C : float
        Main inductance (H) and output capacitance (F).
    L2, C1 : float or None
        Čuk only: output inductor (H) and energy-transfer capacitor (F).
    K, K_crit : float
        Dimensionless K = 2 L_e/(R Ts) and its CCM/DCM boundary at this duty.
    mode : str
        ``"CCM"`` or ``"DCM"`` for the designed values.
    current_ripple, voltage_ripple : float
        Peak-to-peak inductor current ripple (A) and output voltage ripple (V).
    """

    topology: str
    vin: float
    vout: float
    R: float
    fs: float
    duty: float
    L: float
    C: float
    K: float
    K_crit: float
    mode: str
    current_ripple: float
    voltage_ripple: float
    L2: float | None = None
    C1: float | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def Ts(self) -> float:
        return 1.0 / self.fs


def ccm_duty(topology: str, vin: float, vout: float) -> float:
    """Duty cycle that gives ``vout`` from ``vin`` in CCM (ideal elements).

    Raises
    ------
    ValueError
        If the ratio is not reachable by the topology.
    """
    topology = _check_topology(topology)
    M = vout / vin
    if topology == "buck":
        if not 0 < M < 1:
            raise ValueError(f"a buck converter needs 0 < Vout/Vin < 1, got {M:.4g}")
        return M
    if topology == "boost":
        if not M > 1:
            raise ValueError(f"a boost converter needs Vout/Vin > 1, got {M:.4g}")
        return 1.0 - 1.0 / M
    if not M < 0:
        raise ValueError(f"a {topology} converter inverts: needs Vout/Vin < 0, got {M:.4g}")
    return -M / (1.0 - M)


def conversion_ratio(topology: str, duty: float, K: float | None = None) -> float:
    """Steady-state Vout/Vin at duty D; with K given, accounting for DCM (Erickson table 5.2)."""
    topology = _check_topology(topology)
    D = duty
    ccm = {"buck": D, "boost": 1 / (1 - D), "buck-boost": -D / (1 - D), "cuk": -D / (1 - D)}[
        topology
    ]
    if K is None or K >= k_crit(topology, D):
        return ccm
    if topology == "buck":
        return 2.0 / (1.0 + math.sqrt(1.0 + 4.0 * K / D**2))
    if topology == "boost":
        return (1.0 + math.sqrt(1.0 + 4.0 * D**2 / K)) / 2.0
    return -D / math.sqrt(K)


def k_crit(topology: str, duty: float) -> float:
    """CCM/DCM boundary K_crit(D) (Erickson eq. 5.21 and table 5.2)."""
    topology = _check_topology(topology)
    D = duty
    return {"buck": 1 - D, "boost": D * (1 - D) ** 2, "buck-boost": (1 - D) ** 2,
            "cuk": (1 - D) ** 2}[topology]


def design(
    topology: str,
    vin: float,
    vout: float,
    fs: float,
    *,
    R: float | None = None,
    pout: float | None = None,
    current_ripple: float = 0.2,
    voltage_ripple: float = 0.01,
) -> ConverterDesign:
    """Choose L and C of a CCM converter from specifications.

    Parameters
    ----------
    topology : str
        ``"buck"``, ``"boost"``, ``"buck-boost"`` or ``"cuk"``.
    vin, vout : float
        Input and output voltage, V (vout negative for buck-boost and Čuk).
    fs : float
        Switching frequency, Hz.
    R, pout : float
        The load, as a resistance (Ω) or an output power (W); give exactly one.
    current_ripple : float
        Peak-to-peak inductor current ripple as a fraction of the inductor's DC current.
    voltage_ripple : float
        Peak-to-peak output voltage ripple as a fraction of |vout|.

    Returns
    -------
    ConverterDesign
        With ``mode`` the operating mode of the chosen values (CCM unless the ripple target
        exceeds 2, i.e. the inductor current reaches zero).
    """
    topology = _check_topology(topology)
    if (R is None) == (pout is None):
        raise ValueError("give the load as exactly one of R (ohm) or pout (W)")
    for name, val in (("vin", vin), ("fs", fs), ("current_ripple", current_ripple),
                      ("voltage_ripple", voltage_ripple)):
        if not val > 0:
            raise ValueError(f"{name} must be positive, got {val}")
    if R is None:
        if not pout > 0:
            raise ValueError(f"pout must be positive, got {pout}")
        R = vout**2 / pout
    if not R > 0:
        raise ValueError(f"R must be positive, got {R}")
    D = ccm_duty(topology, vin, vout)
    Ts = 1.0 / fs
    iout = abs(vout) / R
    dv = voltage_ripple * abs(vout)
    notes: list[str] = []
    L2 = C1 = None
    if topology == "buck":
        IL = iout
        di = current_ripple * IL
        # on-interval: v_L = Vin - Vout for D Ts (Erickson eq. 2.19)
        L = (vin - vout) * D * Ts / di
        # output ripple: the triangular ripple current charges C (Erickson eq. 2.49 / sec. 2.5)
        C = di * Ts / (8.0 * dv)
        L_e = L
    elif topology == "boost":
        IL = iout / (1 - D)
        di = current_ripple * IL
        L = vin * D * Ts / di  # on-interval: v_L = Vin
        C = vout * D * Ts / (R * dv)  # on-interval: C discharged by the load alone
        L_e = L
    elif topology == "buck-boost":
        IL = iout / (1 - D)
        di = current_ripple * IL
        L = vin * D * Ts / di
        C = abs(vout) * D * Ts / (R * dv)
        L_e = L
    else:  # cuk: input inductor L, output inductor L2, transfer capacitor C1, output C
        IL1 = iout * D / (1 - D)
        IL2 = iout
        L = vin * D * Ts / (current_ripple * IL1)
        L2 = vin * D * Ts / (current_ripple * IL2)
        di = current_ripple * IL2
        C = di * Ts / (8.0 * dv)
        # C1 carries IL1 while the switch is off; its ripple is set to the same fraction of V_C1
        vc1 = vin / (1 - D)
        C1 = IL1 * (1 - D) * Ts / (voltage_ripple * vc1)
        L_e = L * L2 / (L + L2)
        notes.append("C1 sized for the same relative ripple on v(C1) = Vin/(1-D)")
    K = 2.0 * L_e / (R * Ts)
    kc = k_crit(topology, D)
    mode = "CCM" if K > kc else "DCM"
    if mode == "DCM":
        notes.append("the ripple target makes the inductor current reach zero: DCM")
    return ConverterDesign(
        topology=topology, vin=vin, vout=vout, R=R, fs=fs, duty=D, L=L, C=C, K=K, K_crit=kc,
        mode=mode, current_ripple=di, voltage_ripple=dv, L2=L2, C1=C1, notes=notes,
    )


def _check_topology(topology: str) -> str:
    t = topology.lower().replace("_", "-").replace("č", "c")
    if t == "buckboost":
        t = "buck-boost"
    if t not in TOPOLOGIES:
        raise ValueError(f"unknown topology {topology!r}; choose one of {', '.join(TOPOLOGIES)}")
    return t
