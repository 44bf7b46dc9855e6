"""Numbers as journals print them (APA style): p < .001, no leading zero for quantities that cannot
exceed 1, fixed decimals, and no rounding noise (-2.2e-16 is printed as 0.00)."""

from __future__ import annotations

import numpy as np
import pandas as pd

DECIMALS = 2


def number(value: float, decimals: int = DECIMALS) -> str:
    """A number with fixed decimals; "" for a missing value and no "-0.00".

    Examples
    --------
    >>> from microg.analysis.apa import number
    >>> number(-2.22e-16), number(18.4167), number(float("nan"))
    ('0.00', '18.42', '')
    """
    if pd.isna(value):
        return ""
    if not np.isfinite(value):
        return "inf" if value > 0 else "-inf"
    text = f"{value:.{decimals}f}"
    return text[1:] if float(text) == 0 and text.startswith("-") else text


def bounded(value: float, decimals: int = DECIMALS) -> str:
    """A quantity that cannot exceed 1 in size (p, eta squared, epsilon, r): no leading zero.

    Examples
    --------
    >>> from microg.analysis.apa import bounded
    >>> bounded(0.6612), bounded(-0.2175), bounded(1.0)
    ('.66', '-.22', '1.00')
    """
    text = number(value, decimals)
    return text.replace("0.", ".", 1) if text.lstrip("-").startswith("0.") else text


def p_value(p: float) -> str:
    """p as journals print it, with its relation sign: "< .001", "= .023", "> .999".

    Examples
    --------
    >>> from microg.analysis.apa import p_value
    >>> p_value(7.141e-08), p_value(0.0234), p_value(1.0)
    ('< .001', '= .023', '> .999')
    """
    if pd.isna(p):
        return ""
    if p < 0.001:
        return "< .001"
    if p >= 0.9995:  # would print as 1.000
        return "> .999"
    return f"= {bounded(p, 3)}"


def p_cell(p: float) -> str:
    """p for a table cell: "< .001", ".023", "> .999"."""
    return p_value(p).removeprefix("= ")


def degrees(df: float) -> str:
    """Degrees of freedom: whole numbers as such, corrected ones with two decimals."""
    if pd.isna(df):
        return ""
    return f"{df:.0f}" if float(df).is_integer() else number(df)


def interval(low: float, high: float, format_one=number) -> str:
    """A confidence interval: "[-4.52, -1.90]"."""
    if pd.isna(low) or pd.isna(high):
        return ""
    return f"[{format_one(low)}, {format_one(high)}]"


def f_test(F: float, df1: float, df2: float, p: float) -> str:
    """ "F(1.13, 31.57) = 55.28, p < .001" """
    return f"F({degrees(df1)}, {degrees(df2)}) = {number(F)}, p {p_value(p)}"


def t_test(T: float, df: float, p: float) -> str:
    """ "t(27) = -8.10, p < .001" """
    return f"t({degrees(df)}) = {number(T)}, p {p_value(p)}"


def chi_square(chi2: float, df: float, p: float) -> str:
    """ "χ²(2) = 3.81, p = .149" """
    return f"\u03c7\u00b2({degrees(df)}) = {number(chi2)}, p {p_value(p)}"
