"""The units of FRF files: the frequency axis and the FRF ordinate, read from their labels and
converted to SI (Hz; m/s^2/N, m/s/N or m/N), or refused when unknown.

Every FRF reader (UFF 58, `.npz`, CSV) passes its labels through `abscissa_factor` and
`ordinate_factor`, so an axis in rad/s or an accelerance in g/N is converted, never read as Hz
or m/s^2/N. An empty label means SI (Hz; the form's SI unit), as UFF writers that leave the
label blank intend; any other label must be one of the known ones below.
"""

from __future__ import annotations

import math

#: Frequency-axis labels (lower case, blanks removed) -> factor to Hz
ABSCISSA_TO_HZ = {"hz": 1.0, "1/s": 1.0, "cps": 1.0, "rad/s": 1 / (2 * math.pi), "rad/sec": 1 / (2 * math.pi),
                  "cpm": 1 / 60, "rpm": 1 / 60, "1/min": 1 / 60}
#: UFF abscissa specific data types that are a frequency axis: 18 frequency (Hz unless the label
#: says otherwise), 19 rpm (cycles per minute), 0/1 unknown or general (the label decides)
UFF_FREQUENCY_TYPES = {0: None, 1: None, 18: "hz", 19: "rpm"}

_G = 9.80665          # standard gravity, m/s^2 per g
_LBF = 4.4482216152605  # N per pound-force
#: Response labels per FRF form -> factor to the SI response (m/s^2, m/s, m)
RESPONSE_TO_SI = {
    "accelerance": {"m/s^2": 1.0, "m/s2": 1.0, "m/s**2": 1.0, "mm/s^2": 1e-3, "mm/s2": 1e-3, "g": _G,
                    "in/s^2": 0.0254, "in/s2": 0.0254},
    "mobility": {"m/s": 1.0, "mm/s": 1e-3, "in/s": 0.0254},
    "receptance": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "in": 0.0254},
}
#: Force labels -> factor to N
FORCE_TO_SI = {"n": 1.0, "kn": 1e3, "lbf": _LBF}
#: The SI unit of each form, as the project writes it
SI_UNITS = {"accelerance": "m/s^2/N", "mobility": "m/s/N", "receptance": "m/N"}


def _clean(label) -> str:
    """The label without blanks and parentheses; '' for none (UFF writes NONE for an empty field)."""
    text = "".join(str(label or "").split()).replace("(", "").replace(")", "")
    return "" if text.upper() == "NONE" else text


def abscissa_factor(label, where: str, error, uff_type: int | None = None) -> float:
    """The factor that turns the frequency axis labelled `label` into Hz; `error` (naming `where`)
    if the label or the UFF specific data type `uff_type` is not a frequency axis we know."""
    text = _clean(label).lower()
    if uff_type is not None:
        if uff_type not in UFF_FREQUENCY_TYPES:
            raise error(f"{where}: the abscissa's data type {uff_type} is not a frequency axis (18 frequency, "
                        "19 rpm): an FRF needs frequency lines")
        text = text or (UFF_FREQUENCY_TYPES[uff_type] or "")
    if not text:
        return 1.0
    if text not in ABSCISSA_TO_HZ:
        raise error(f"{where}: unknown frequency unit {str(label).strip()!r}; use one of Hz, rad/s, CPM")
    return ABSCISSA_TO_HZ[text]


def ordinate_factor(label, form: str, where: str, error) -> float:
    """The factor that turns an FRF of `form` in the units `label` (response over force, e.g.
    'g/N', 'mm/s/N', '(m/s^2)/N') into SI; 1 for an empty label; `error` naming `where` for a unit
    that is unknown or does not match the form (a velocity unit on an accelerance)."""
    text = _clean(label)
    if not text:
        return 1.0
    response, _, force = text.rpartition("/")
    known = RESPONSE_TO_SI[form]
    if response not in known or force.lower() not in FORCE_TO_SI:
        other = next((f for f, units in RESPONSE_TO_SI.items() if response in units and f != form), None)
        why = (f"a {other} unit on an {form} FRF" if other and force.lower() in FORCE_TO_SI
               else f"use one of {', '.join(u + '/N' for u in known)} (or over kN, lbf)")
        raise error(f"{where}: unknown FRF unit {str(label).strip()!r} for {form}: {why}")
    return known[response] / FORCE_TO_SI[force.lower()]
