"""Figures and verdicts of the comparison reports: readable widths for any value a table can hold."""

from __future__ import annotations

import math


def fmt(x: float) -> str:
    """A figure in a readable width: 4 significant digits, scientific when large or tiny."""
    x = float(x)
    if not math.isfinite(x):
        return str(x)
    return f"{x:.4g}"


def fixed(x: float, decimals: int = 6) -> str:
    """``decimals`` places for figures of moderate size (albedos), else :func:`fmt`: never
    wider than about a dozen characters."""
    x = float(x)
    if math.isfinite(x) and abs(x) < 1e3:
        return f"{x:.{decimals}f}"
    return fmt(x)


def angle(radians: float) -> str:
    """An angle in degrees, 7 characters wide up to 1e4 degrees (beyond, 4 significant digits)."""
    degrees = math.degrees(float(radians))
    if math.isfinite(degrees) and abs(degrees) < 1e4:
        return f"{degrees:7.2f}"
    return f"{fmt(degrees):>7}"


def verdict(report, tested: str) -> str:
    """``PASS``, ``FAIL`` or, when nothing failed but some chi-square had fewer than two
    categories, ``NOT TESTABLE`` (never a pass: :mod:`vcavity.analytic.statistics`).

    ``report`` has ``passed``, ``per_test_level`` and ``directions`` whose items carry a
    ``chi_square`` and an ``albedo_test``; ``tested`` names the order in the message.
    """
    if report.passed:
        return "PASS"
    level = report.per_test_level
    failed = [d for d in report.directions
              if d.chi_square.failure or (d.chi_square.testable and not d.chi_square.passed(level))
              or not d.albedo_test.passed(level)]
    if failed:
        return "FAIL"
    untestable = [d for d in report.directions if not d.chi_square.testable]
    return (f"NOT TESTABLE (the chi-square of {len(untestable)} direction(s) has fewer than two categories: "
            f"too few paths for the {tested} test; not a pass)")
