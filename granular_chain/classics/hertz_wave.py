"""The exact travelling wave of a Hertz chain, solved independently of the engine.

A chain of equal masses ``m`` with contact force ``k delta^p`` (``p = 3/2``: Hertz
spheres, exponent ``n = p + 1 = 5/2``), granule ``i`` displaced by ``u_i``. The
overlap of contact ``i`` (between granules ``i-1`` and ``i``) is
``r_i = u_{i-1} - u_i`` and obeys (scaled units, ``m = k = 1``)::

    r_i'' = f(r_{i+1}) - 2 f(r_i) + f(r_{i-1}),    f(r) = max(r, 0)^p.        (1)

A wave ``r_i(t) = R(i - c t)`` of speed ``c`` (granules per unit time) solves the
advance-delay equation ``c^2 R''(x) = f(R(x+1)) - 2 f(R(x)) + f(R(x-1))``; in
Fourier space (``x -> xi``) ``c^2 R^ = sinc^2(xi/2) f(R)^``, i.e. the
convolution with the tent ``Lambda(x) = max(1 - |x|, 0)``::

    c^2 R = Lambda * f(R)                                                     (2)

(English & Pego, Proc. AMS 133, 1763 (2005)). With ``R = c^(2/(p-1)) S`` (``c^4 S``
for Hertz) the speed drops out: ``S = Lambda * S^p`` (3), one profile for every
amplitude. The particle velocity follows from ``m u_i'' = f(r_i) - f(r_{i+1})``::

    v(x) = (1/c) int_x^{x+1} f(R(s)) ds = c^(2p/(p-1) - 1) W(x),
    W(x) = int_x^{x+1} S(s)^p ds                                              (4)

so ``v_max = c^5 W_max`` (Hertz) and ``c = W_max^(-1/5) v_max^(1/5)``: the constant
``W_max^(-1/5)`` is what a measured speed over ``v_max^(1/5)`` is compared with.

Equation (3) is solved by the Petviashvili iteration (Ahnert & Pikovsky, PRE 79,
026209 (2009), Sec. III; V. I. Petviashvili, Sov. J. Plasma Phys. 2, 257 (1976))
on a periodic grid: ``S <- M^(p/(p-1)) Lambda * S^p`` with the stabilising factor
``M = <S, S> / <S, Lambda * S^p>``. The wave decays faster than any exponential,
so a period of 40 granules holds it to roundoff, and the grid's Fourier series
evaluates ``S``, ``W`` and their integrals spectrally. Nothing here calls the
engine's steppers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["TravellingWave", "solve_travelling_wave", "NESTERENKO_CONSTANT"]

#: Nesterenko's long-wave constant ``(16/25)^(1/5)``: ``c = 0.9146 v_max^(1/5)``
#: (granules per unit time, scaled units; :func:`granular_chain.diagnostics.nesterenko_speed`).
NESTERENKO_CONSTANT = (16.0 / 25.0) ** 0.2


def _sinc(xi: np.ndarray) -> np.ndarray:
    """``sin(xi/2) / (xi/2)``: the Fourier transform of the unit box centred on 0."""
    return np.sinc(xi / (2.0 * np.pi))


@dataclass(frozen=True)
class TravellingWave:
    """The solution ``S = Lambda * S^p`` of eq. (3) on a periodic grid.

    Attributes
    ----------
    p : float
        Force exponent (``n - 1``; 3/2 for Hertz spheres).
    spacing : float
        Grid spacing, granules.
    spectrum : ndarray, shape (G,)
        FFT of ``S`` on the grid ``x_j = j * spacing`` (wrapped: the second half
        holds negative ``x``).
    iterations : int
        Petviashvili iterations taken.
    residual : float
        ``max |S - Lambda * S^p|`` on the grid (dimensionless, ``S`` peaks at 1.487).
    """

    p: float
    spacing: float
    spectrum: np.ndarray
    iterations: int
    residual: float

    @property
    def xi(self) -> np.ndarray:
        """Angular wavenumbers of the grid, per granule."""
        return 2.0 * np.pi * np.fft.fftfreq(self.spectrum.size, d=self.spacing)

    def _series(self, coefficients: np.ndarray, x) -> np.ndarray:
        """The Fourier series with ``coefficients`` (an FFT on the grid) at the points x."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        phase = np.exp(1j * np.outer(x, self.xi))
        return (phase @ coefficients).real / coefficients.size

    @property
    def force_spectrum(self) -> np.ndarray:
        """FFT of ``S^p`` on the grid."""
        s = np.fft.ifft(self.spectrum).real
        return np.fft.fft(np.maximum(s, 0.0) ** self.p)

    def profile(self, x) -> np.ndarray:
        """The scaled overlap ``S(x)`` of eq. (3) at the points ``x`` (granules).

        Parameters
        ----------
        x : array_like
            Positions relative to the wave's centre, granules.

        Returns
        -------
        ndarray
            ``S(x)`` (dimensionless); the overlap is ``c^(2/(p-1)) S``.
        """
        return self._series(self.spectrum, x)

    def scaled_velocity(self, x) -> np.ndarray:
        """``W(x) = int_x^{x+1} S^p`` of eq. (4) (the velocity is ``c^(2p/(p-1)-1) W``).

        Parameters
        ----------
        x : array_like
            Positions relative to the wave's centre, granules.

        Returns
        -------
        ndarray
            ``W(x)`` (dimensionless), largest at ``x = -1/2``.
        """
        shifted = self.force_spectrum * _sinc(self.xi) * np.exp(0.5j * self.xi)
        return self._series(shifted, x)

    @property
    def w_max(self) -> float:
        """``W_max = W(-1/2) = int_{-1/2}^{1/2} S^p`` (eq. 4), summed spectrally."""
        return float((self.force_spectrum * _sinc(self.xi)).sum().real / self.spectrum.size)

    @property
    def exponent(self) -> float:
        """``2p/(p-1) - 1``: ``v_max = c^exponent W_max`` (5 for Hertz)."""
        return 2.0 * self.p / (self.p - 1.0) - 1.0

    @property
    def speed_constant(self) -> float:
        """``c / v_max^(1/e) = W_max^(-1/e)``, ``e`` = :attr:`exponent` (eq. 4):
        0.907470078412 for Hertz, granules per unit time in scaled units."""
        return self.w_max ** (-1.0 / self.exponent)

    def speed(self, v_max: float) -> float:
        """The wave's speed at peak particle velocity ``v_max``.

        Parameters
        ----------
        v_max : float
            Peak particle velocity (scaled units: ``m = k = 1``).

        Returns
        -------
        float
            ``c``, granules per unit time.
        """
        return self.speed_constant * v_max ** (1.0 / self.exponent)

    def fwhm(self) -> float:
        """Full width at half maximum of the velocity profile ``W`` (eq. 4), granules:
        the half-maximum points found by bisection on the spectral ``W``.

        Returns
        -------
        float
            The width, granules (the same at every amplitude).
        """
        half = 0.5 * self.w_max
        lo, hi = -0.5, 5.0  # W(-1/2) = W_max; W(5) is below 1e-10 of it
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.scaled_velocity(mid)[0] > half else (lo, mid)
        return 2.0 * (0.5 * (lo + hi) + 0.5)

    def energy_constant(self, count: int = 64) -> float:
        """``E / v_max^2`` of the wave on the lattice (kinetic ``v^2/2`` plus contact
        ``f``'s potential ``r^(p+1)/(p+1)``), scaled units, summed over ``count``
        sites around the centre (the tails beyond are below roundoff).

        Parameters
        ----------
        count : int
            Lattice sites summed.

        Returns
        -------
        float
            ``E / v_max^2`` (the same at every amplitude: ``E ~ c^10 ~ v_max^2``).
        """
        x = np.arange(count) - count // 2 + 0.25  # any phase: the energy is conserved
        w, s = self.scaled_velocity(x), np.maximum(self.profile(x), 0.0)
        e = 0.5 * np.sum(w ** 2) + np.sum(s ** (self.p + 1.0)) / (self.p + 1.0)
        return float(e / self.w_max ** 2)


def solve_travelling_wave(p: float = 1.5, length: float = 40.0, spacing: float = 1.0 / 64.0,
                          tol: float = 1e-15, max_iterations: int = 500) -> TravellingWave:
    """Solve eq. (3), ``S = Lambda * S^p``, by the Petviashvili iteration.

    Parameters
    ----------
    p : float
        Force exponent ``n - 1`` (> 1; 3/2 for Hertz spheres).
    length : float
        Period of the grid, granules (the wave must fit with its tails).
    spacing : float
        Grid spacing, granules.
    tol : float
        Stop when the largest change of the spectrum, relative to its largest
        coefficient, is below this.
    max_iterations : int
        Give up after this many iterations.

    Returns
    -------
    TravellingWave

    Raises
    ------
    RuntimeError
        The iteration did not reach ``tol``.
    """
    n = int(round(length / spacing))
    j = np.arange(n)
    x = np.where(j < n // 2, j, j - n) * spacing
    xi = 2.0 * np.pi * np.fft.fftfreq(n, d=spacing)
    tent = _sinc(xi) ** 2
    # start: Nesterenko's long-wave cos^4 hump (any positive even bump converges)
    start = np.cos(np.clip(x * math.sqrt(10.0) / 5.0, -np.pi / 2, np.pi / 2)) ** 4
    spectrum = np.fft.fft(start)
    for it in range(1, max_iterations + 1):
        force = np.fft.fft(np.maximum(np.fft.ifft(spectrum).real, 0.0) ** p)
        stab = np.sum(np.abs(spectrum) ** 2) / np.real(np.sum(np.conj(spectrum) * tent * force))
        new = stab ** (p / (p - 1.0)) * tent * force
        change = np.max(np.abs(new - spectrum)) / np.max(np.abs(new))
        spectrum = new
        if change < tol:
            break
    else:
        raise RuntimeError(f"Petviashvili iteration: change {change:.2e} after "
                           f"{max_iterations} iterations (tol {tol:.0e})")
    s = np.fft.ifft(spectrum).real
    residual = float(np.max(np.abs(
        s - np.fft.ifft(tent * np.fft.fft(np.maximum(s, 0.0) ** p)).real)))
    return TravellingWave(p=p, spacing=spacing, spectrum=spectrum, iterations=it,
                          residual=residual)
