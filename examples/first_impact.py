"""The first impact: a particle of mass 2 striking a floor at 45 degrees, under every law.

Run: ``python examples/first_impact.py``. The contact Jacobian's rows are the contact frame,
normal first; the normal points toward the particle, so an approaching contact has
``Jc[0] @ dq < 0``. By hand, under the paper's law: the sticking impulse (3, -2) lies outside
the friction cone (|pi_t| <= 0.3 pi_n), so the particle slides with pi = (3, -0.9); the
normal velocity rebounds at -e times its approach (-1 -> 0.5), the tangential one falls to
1 - 0.9 / 2 = 0.55, and 1.4475 J of the 2 J are lost.
"""

import numpy as np

import convimpact as ci


def main() -> dict[str, ci.ImpactResult]:
    M = 2.0 * np.eye(2)                        # generalized mass matrix (eq. 3)
    Jc = np.array([[0.0, 1.0],                 # n: up, toward the particle
                   [1.0, 0.0]])                # t: +x
    dq = np.array([1.0, -1.0])                 # theta_dot before the impact
    results = {}
    print(f"{'law':18s} {'regime':7s} {'impulse':>16s} {'v+':>16s} {'T lost':>8s}  all held")
    for law in ci.LAWS:
        r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3, law=law)
        held = all(r.diagnostics.held().values())
        print(f"{law:18s} {r.regime:7s} {np.array2string(r.impulse, precision=4):>16s} "
              f"{np.array2string(r.v_plus, precision=4):>16s} {r.energy_loss:8.4f}  {held}")
        results[law] = r
    return results


if __name__ == "__main__":
    main()
