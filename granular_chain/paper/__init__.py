"""Closed forms and numerical claims of the two-granule paper, as printed and corrected.

Source: A. Rosas, J. Buceta and K. Lindenberg, *Dynamics of Two Granules*
(``shared/seed/two_granules_paper.tex``).  Every closed form and every numerical
claim of the paper is a function here, written exactly **as printed**; where the
printed statement is wrong, a ``*_corrected`` (or ``*_exact``) function sits next
to it and its docstring states the erratum.  ``docs/paper_check.md`` lists
the verdicts and the measured errors; ``tests/test_paper_formulas.py`` proves them.

=============================  ===============================================
module                         contents
=============================  ===============================================
``contact_and_scaling``        Sec. I Eqs. (1)-(3), Appendix A (``hertz_*``, ``scaling_*``)
``coulomb_on_granule2``        Sec. II A, friction on granule 2 (``iia_*``)
``coulomb_on_granule1``        Sec. II B, friction on granule 1 (``iib_*``)
``viscous``                    Sec. III, hydrodynamic friction (``iii_*``)
``reference``                  exact ``n = 2`` collision (:func:`reference_collision_n2`)
``arithmetic``, ``roots``      float64/mpmath dispatch; mpmath root finding
``figures``                    the paper's figures redrawn from the engine
=============================  ===============================================

Units
-----
Everything is in the paper's scaled units (Appendix A): both masses are 1, the
contact *force* is ``delta**(n-1)`` while the overlap ``delta = x1 - x2`` is
positive and zero otherwise (so for ``n = 2`` the spring constant is 1), granule 1
starts at velocity 1 just touching granule 2, which is at rest.  ``x1, x2`` are
displacements from the initial positions, ``t`` is scaled time, ``eta_i`` is the
scaled kinetic (Coulomb) friction force, ``gamma_i`` the scaled hydrodynamic
friction coefficient (force ``-gamma_i * v_i``).

Arithmetic
----------
The closed forms accept floats or numpy arrays (computed in float64 with numpy)
*or* :class:`mpmath.mpf` scalars (computed with mpmath at the current
``mpmath.mp.dps``), so that an exact formula can be checked far below float64
roundoff.  Functions marked *exact/numerical* return mpmath numbers.

The closed forms and the reference use no numba and none of the engine's
code (only its outcome names): they are the yardstick the engine is measured
against. :mod:`granular_chain.paper.figures` (the engine against them) is
imported on its own.
"""
from __future__ import annotations

from .contact_and_scaling import (force_coefficient_from_potential_coefficient, hertz_a_printed,
                                  hertz_force_coefficient_spheres, hertz_potential_corrected,
                                  hertz_potential_printed, scaling_corrected, scaling_printed)
from .coulomb_on_granule1 import (iib_back_sliding_overlap, iib_back_sliding_v1,
                                  iib_backscatter_threshold_eta_exact, iib_collision_exact,
                                  iib_initial_conditions_exact, iib_initial_conditions_small_eta,
                                  iib_max_backscatter_exact, iib_slip_critical_eta_exact,
                                  iib_slip_critical_eta_printed, iib_slip_force_printed,
                                  iib_t0_exact, iib_t0_small_eta, iib_t0_small_eta_next_order,
                                  iib_t0prime_exact, iib_t1_small_eta,
                                  iib_t1_small_eta_next_order, iib_v1, iib_v2, iib_x1, iib_x2)
from .coulomb_on_granule2 import (iia_energy_minimum, iia_energy_ratio, iia_eta_max,
                                  iia_stuck_second_granule_v1, iia_t0, iia_t1, iia_v1, iia_v1s,
                                  iia_v2, iia_v2s, iia_x1, iia_x1_phase1, iia_x2)
from .reference import OUTCOMES, reference_collision_n2, reference_state_n2
from .roots import golden_min
from .viscous import (iii_dvs_ddelta, iii_energy_ratio_zeroth, iii_epsilon, iii_gammas,
                      iii_laplace_exact, iii_laplace_system_printed, iii_omega,
                      iii_optimal_gamma_zeroth, iii_separates, iii_t0,
                      iii_t_separation_first_order, iii_v1s_first_order, iii_v2s_first_order,
                      iii_Xminus_first_order, iii_Xplus_first_order_corrected,
                      iii_Xplus_first_order_printed, iii_xminus_zeroth)

__all__ = [
    # Sec I / Appendix A
    "hertz_potential_printed", "hertz_potential_corrected", "hertz_a_printed",
    "hertz_force_coefficient_spheres", "force_coefficient_from_potential_coefficient",
    "scaling_printed", "scaling_corrected",
    # Sec II A
    "iia_x1_phase1", "iia_t0", "iia_x1", "iia_x2", "iia_v1", "iia_v2", "iia_t1",
    "iia_v1s", "iia_v2s", "iia_eta_max", "iia_energy_ratio", "iia_energy_minimum",
    "iia_stuck_second_granule_v1",
    # Sec II B
    "iib_x1", "iib_x2", "iib_v1", "iib_v2", "iib_t0_small_eta",
    "iib_t0_small_eta_next_order", "iib_t0_exact", "iib_t0prime_exact",
    "iib_initial_conditions_small_eta", "iib_initial_conditions_exact",
    "iib_slip_force_printed", "iib_slip_critical_eta_printed",
    "iib_slip_critical_eta_exact", "iib_t1_small_eta", "iib_t1_small_eta_next_order",
    "iib_back_sliding_overlap", "iib_back_sliding_v1", "iib_collision_exact",
    "iib_backscatter_threshold_eta_exact", "iib_max_backscatter_exact",
    # Sec III
    "iii_gammas", "iii_omega", "iii_t0", "iii_separates", "iii_xminus_zeroth",
    "iii_laplace_system_printed", "iii_laplace_exact", "iii_Xplus_first_order_printed",
    "iii_Xplus_first_order_corrected", "iii_Xminus_first_order", "iii_epsilon",
    "iii_t_separation_first_order", "iii_v1s_first_order", "iii_v2s_first_order",
    "iii_dvs_ddelta", "iii_energy_ratio_zeroth", "iii_optimal_gamma_zeroth",
    # reference solver
    "OUTCOMES", "reference_collision_n2", "reference_state_n2",
    # golden-section minimisation (used by the tests on the engine's curves too)
    "golden_min",
]
