"""Closed-form references for the sustained-contact scenes, derived here from first principles.

Nothing in this module calls convimpact: each function is derived in its docstring (Newton-
Euler equations, energy and angular-momentum balances) so the simulator's results can be
checked against an independent source. The scene modules in ``problems/`` record the same
constants in their ``parameters``; a test that compares the two catches a slip in either.

Conventions: y is vertical, gravity g > 0 points along -y; angles in radians.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad

G = 9.81


# -- Housner's rocking block ------------------------------------------------------------------
def housner_p2(R: float, g: float = G) -> float:
    """p^2 = m g R / I_O = 3 g / (4 R) for a rectangular block pivoting on a corner.

    I_O = I_G + m R^2 with I_G = m (w^2 + h^2) / 12 = m (2R)^2 / 12 = m R^2 / 3, so
    I_O = 4/3 m R^2.
    """
    return 3.0 * g / (4.0 * R)


def housner_first_landing_time(tilt: float, alpha: float, R: float, g: float = G) -> float:
    """Time from release at rest at the tilt theta0 < alpha until the block lands flat.

    Pivoting on a corner the block is a pendulum: I_O theta'' = -m g R sin(alpha - theta),
    theta the rotation from the flat position toward the lifted side (the centre of mass is
    at the angle alpha - theta from the vertical through the pivot, at the height
    R cos(alpha - theta)). The energy integral from rest at theta0 gives
    theta'^2 = 2 p^2 [cos(alpha - theta0) - cos(alpha - theta)], so

        T = integral_0^theta0 dtheta / sqrt(2 p^2 F(theta)),
        F(theta) = cos(alpha - theta0) - cos(alpha - theta)
                 = 2 sin(alpha - (theta + theta0)/2) sin((theta0 - theta)/2).

    F vanishes like (theta0 - theta) at the release point (an integrable 1/sqrt singularity).
    The substitution theta = theta0 (1 - s^2), dtheta = -2 theta0 s ds, removes it:

        T = integral_0^1 2 theta0 ds / sqrt(2 p^2 theta0 sin(alpha - theta0 + theta0 s^2/2)
                                             sinc(theta0 s^2 / 2)),

    with sinc(x) = sin(x)/x, a smooth integrand that ``scipy.integrate.quad`` integrates to
    round-off. (The product form of F also avoids the cancellation of the two cosines.)
    """
    if not 0.0 < tilt < alpha:
        raise ValueError(f"the block lands only for 0 < tilt < alpha, got {tilt}, {alpha}")
    p2 = housner_p2(R, g)

    def integrand(s: float) -> float:
        x = 0.5 * tilt * s * s
        return 2.0 * tilt / np.sqrt(2.0 * p2 * tilt * np.sin(alpha - tilt + x) * np.sinc(x / np.pi))

    val, err = quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)
    return float(val)


def housner_first_landing_time_linear(tilt: float, alpha: float, R: float, g: float = G) -> float:
    """Housner's small-angle result (1/p) arccosh(1 / (1 - tilt/alpha)).

    Linearising sin(alpha - theta) ~ alpha - theta: theta'' = p^2 (theta - alpha), so
    alpha - theta = (alpha - theta0) cosh(p t), and theta = 0 when
    cosh(p t) = alpha / (alpha - theta0).
    """
    return float(np.arccosh(1.0 / (1.0 - tilt / alpha)) / np.sqrt(housner_p2(R, g)))


def housner_landing_times(tilt: float, alpha: float, R: float, n: int,
                          g: float = G) -> np.ndarray:
    """Times of the first n landings of a block released at rest at ``tilt``.

    The first landing takes housner_first_landing_time(tilt); between landings k and k+1
    the block swings up to rest at the amplitude theta_k (housner_amplitude_map) and back,
    which by time reversal of the pendulum motion takes twice the landing time from theta_k.
    """
    times, theta, t = [], tilt, housner_first_landing_time(tilt, alpha, R, g)
    for _ in range(n):
        times.append(t)
        theta = housner_amplitude_map(theta, alpha)
        t += 2.0 * housner_first_landing_time(theta, alpha, R, g)
    return np.array(times)


def housner_rest_time(tilt: float, alpha: float, R: float, g: float = G,
                      rtol: float = 1e-10) -> float:
    """Time at which the rocking stops: the accumulation point of the landing times (Zeno).

    For small amplitudes cos(alpha - theta) - cos alpha ~ theta sin alpha, so the map is
    theta_+ ~ r^2 theta_- and the swing time ~ sqrt(theta): the half-cycle times then shrink
    by the factor r per landing and their tail after the last summed term T is T r / (1 - r).
    """
    r = housner_restitution(alpha)
    theta = tilt
    total = housner_first_landing_time(tilt, alpha, R, g)
    for _ in range(100000):
        theta = housner_amplitude_map(theta, alpha)
        half = 2.0 * housner_first_landing_time(theta, alpha, R, g)
        total += half
        if half * r / (1.0 - r) <= rtol * total:
            break
    return float(total + half * r / (1.0 - r))


def housner_restitution(alpha: float) -> float:
    """Ratio r = omega_+ / omega_- of the angular velocities at a landing: 1 - 3/2 sin^2 alpha.

    Just before landing the block turns at omega about the old corner O; the impulse acts at
    the new corner O' (plastic, no slip; the old corner lifts), so the angular momentum about
    O' is conserved: I_G omega + m (G - O') x v_G = I_O omega_+, v_G = omega z x (G - O). With
    the flat block's corners at (+-w/2, 0) and G = (0, h/2):
    (G - O') x v_G = omega (G - O') . (G - O) = omega (h^2 - w^2)/4 = omega R^2 cos(2 alpha),
    so omega_+ / omega_- = (1/3 + cos 2 alpha) / (4/3) = 1 - 3/2 sin^2 alpha.
    """
    return float(1.0 - 1.5 * np.sin(alpha) ** 2)


def housner_amplitude_map(theta_minus: float, alpha: float) -> float:
    """Next rocking amplitude theta_+ from the amplitude theta_- before a landing.

    Energy from rest at theta_- to the landing: omega_-^2 = 2 p^2 [cos(alpha - theta_-) -
    cos alpha]; the landing multiplies omega by r = housner_restitution(alpha); energy from
    the landing to rest at theta_+: omega_+^2 = 2 p^2 [cos(alpha - theta_+) - cos alpha].
    Hence cos(alpha - theta_+) - cos alpha = r^2 [cos(alpha - theta_-) - cos alpha].
    """
    r = housner_restitution(alpha)

    def lift(theta: float) -> float:  # cos(alpha - theta) - cos(alpha), without cancellation
        return 2.0 * np.sin(alpha - 0.5 * theta) * np.sin(0.5 * theta)

    target = r * r * lift(theta_minus)
    c = np.cos(alpha) + target
    theta = float(alpha - np.arccos(np.clip(c, -1.0, 1.0)))
    if theta < 1e-3 * alpha:  # arccos loses digits there: Newton on the product form
        theta = target / np.sin(alpha)
        for _ in range(8):
            theta -= (lift(theta) - target) / np.sin(alpha - theta)
    return float(theta)


# -- McGeer's rimless wheel ---------------------------------------------------------------------
def rimless_wheel_eta(n_spokes: int, rho: float) -> float:
    """Angular-velocity ratio at a foot strike: (cos(2 pi/n) + rho^2) / (1 + rho^2).

    Angular momentum about the new foot P' is conserved (the strike impulse passes through
    P', the old foot carries no impulse): m (rho l)^2 w- + m (G - P') x (w- z x (G - P)) =
    m l^2 (1 + rho^2) w+, and (G - P') . (G - P) = l^2 cos(2 pi / n), the angle between spokes.
    """
    return float((np.cos(2.0 * np.pi / n_spokes) + rho ** 2) / (1.0 + rho ** 2))


def rimless_wheel_step_map(omega_minus: float, n_spokes: int, slope: float, l: float,
                           rho: float, g: float = G) -> float | None:
    """Pre-strike angular velocity of the next step from this one's (None: it stops).

    After the strike the new stance leg leans back (uphill) by a - slope from the vertical
    (a = pi/n): it must carry the hub up by l (1 - cos(a - slope)) to pass the vertical, then
    the leg falls to lean forward by a + slope, where the next foot strikes. Energy with the
    inertia J = m l^2 (1 + rho^2) about the foot:
    w^2 changes by 2 g [cos(a - slope) - cos(a + slope)] / (l (1 + rho^2)) over the step.
    """
    a = np.pi / n_spokes
    k = 2.0 * g / (l * (1.0 + rho ** 2))
    w_plus = rimless_wheel_eta(n_spokes, rho) * omega_minus
    if w_plus ** 2 <= k * (1.0 - np.cos(a - slope)):
        return None
    return float(np.sqrt(w_plus ** 2 + k * (np.cos(a - slope) - np.cos(a + slope))))


def rimless_wheel_stance_time(omega_start: float, sigma_start: float, sigma_end: float,
                              l: float, rho: float, g: float = G) -> float:
    """Time for the stance leg to turn from sigma_start to sigma_end (angles from the vertical,
    forward positive) starting at the angular velocity omega_start > 0.

    An inverted pendulum about the foot: J sigma'' = m g l sin(sigma), so
    sigma'^2 = omega_start^2 + 2 g (cos sigma_start - cos sigma) / (l (1 + rho^2)) and
    T = integral dsigma / sigma' (regular as long as sigma' > 0 on the way). For the steady
    step take omega_plus_steady from slope - pi/n to slope + pi/n; for the scene's first
    strike, omega0 from 0 to slope + pi/n.
    """
    k = 2.0 * g / (l * (1.0 + rho ** 2))

    def rate(sig: float) -> float:
        return np.sqrt(omega_start ** 2 + k * (np.cos(sigma_start) - np.cos(sig)))

    if omega_start <= 0 or min(rate(s) ** 2 for s in np.linspace(sigma_start, sigma_end, 201)
                               ) <= 0.0:
        raise ValueError("the stance leg does not reach sigma_end")
    val, _ = quad(lambda sig: 1.0 / rate(sig), sigma_start, sigma_end, epsabs=0.0,
                  epsrel=1e-13, limit=200)
    return float(val)


def rimless_wheel_steady_speed(n_spokes: int, slope: float, l: float, rho: float,
                               g: float = G) -> tuple[float, float]:
    """McGeer's fixed point (omega just before, omega just after a strike).

    In the steady gait the energy the strike removes, J (w-^2 - w+^2) / 2 = J w-^2 (1 -
    eta^2) / 2, equals the potential energy released per step, m g 2 l sin(pi/n) sin(slope)
    (the hub descends that much between strikes: the stance leg turns from a - slope behind
    to a + slope ahead of the vertical). With J = m l^2 (1 + rho^2):

        w-^2 = 4 g sin(pi/n) sin(slope) / (l (1 + rho^2) (1 - eta^2)),   w+ = eta w-.

    (Whether the gait exists, i.e. w+ passes the vertical, is checked by the step map.)
    """
    eta = rimless_wheel_eta(n_spokes, rho)
    drop = 2.0 * l * np.sin(np.pi / n_spokes) * np.sin(slope)
    w_minus = np.sqrt(2.0 * g * drop / (l * l * (1.0 + rho ** 2) * (1.0 - eta ** 2)))
    return float(w_minus), float(eta * w_minus)


# -- sliding, rolling, stopping -----------------------------------------------------------------
def ball_rolling(v0: float, omega0: float, r: float, mu: float,
                 g: float = G) -> tuple[float, float]:
    """(time until rolling, final speed) of a uniform solid ball launched sliding (planar).

    Coordinates: x to the right, omega counter-clockwise; the bottom point moves at
    s = v + r omega (rolling forward: omega = -v / r). Friction F = -mu m g sign(s) at the
    bottom: m v' = F, I omega' = r F (moment of F at -r y about the centre), I = 2/5 m r^2,
    so s' = F/m + r^2 F / I = 3.5 F / m: |s| falls at 3.5 mu g and the ball rolls after
    |s0| / (3.5 mu g). The angular momentum about the contact point, I omega - m r v, is
    conserved (friction and the normal force pass through it, gravity's arm is zero), so the
    rolling speed v_f solves -I v_f / r - m r v_f = I omega0 - m r v0:
    v_f = (5 v0 - 2 r omega0) / 7.
    """
    s0 = v0 + r * omega0
    return abs(s0) / (3.5 * mu * g), (5.0 * v0 - 2.0 * r * omega0) / 7.0


def ball_rolling_spatial(v0, omega0, r: float, mu: float,
                         g: float = G) -> tuple[float, np.ndarray, np.ndarray]:
    """(time until rolling, final velocity, final angular velocity): a ball on the floor y = 0.

    The bottom point moves at s = v + w x (-r e_y). Friction F = -mu m g s/|s|: m v' = F,
    I w' = (-r e_y) x F, so s' = F/m - r (w' x e_y) = F/m + (r^2/I) F = 3.5 F/m (F is
    horizontal). s keeps its direction and |s| falls at 3.5 mu g: rolling after
    t = |s0| / (3.5 mu g), with v_f = v0 - mu g t s0/|s0| = v0 - s0 / 3.5 and w_f the rolling
    spin e_y x v_f / r (+ the vertical spin, unchanged by friction).
    """
    v0, omega0 = np.asarray(v0, dtype=float), np.asarray(omega0, dtype=float)
    ey = np.array([0.0, 1.0, 0.0])
    s0 = v0 + np.cross(omega0, -r * ey)
    t = float(np.linalg.norm(s0)) / (3.5 * mu * g)
    vf = v0 - s0 / 3.5
    wf = np.cross(ey, vf) / r + (omega0 @ ey) * ey
    return t, vf, wf


def box_stopping(v0: float, mu: float, g: float = G) -> tuple[float, float]:
    """(time, distance) for a block sliding on a level floor to stop: v0/(mu g), v0^2/(2 mu g).

    The normal forces total m g, so the friction totals mu m g against the motion.
    """
    return abs(v0) / (mu * g), v0 * v0 / (2.0 * mu * g)


def incline(mu: float, slope: float, g: float = G) -> float:
    """Acceleration down the slope of a block released at rest: 0 if mu >= tan(slope).

    Normal force m g cos(slope); holding needs the friction m g sin(slope) <= mu m g
    cos(slope); sliding, the friction mu m g cos(slope) opposes the gravity component
    m g sin(slope): a = g (sin(slope) - mu cos(slope)).
    """
    if mu >= np.tan(slope):
        return 0.0
    return float(g * (np.sin(slope) - mu * np.cos(slope)))


def incline_stopping(v0_down: float, mu: float, slope: float,
                     g: float = G) -> tuple[float, float] | None:
    """(time, distance down the slope) until a block launched at v0_down (> 0: downhill)
    stops slipping, or None if it never stops.

    Sliding down: deceleration g (mu cos - sin) (None unless positive); sliding up:
    deceleration g (sin + mu cos); then t = |v0| / dec, distance v0 |v0| / (2 dec).
    """
    if v0_down == 0.0:
        return (0.0, 0.0) if mu >= np.tan(slope) else None
    dec = g * (mu * np.cos(slope) - np.sin(slope)) if v0_down > 0 else \
        g * (np.sin(slope) + mu * np.cos(slope))
    if dec <= 0.0:
        return None
    return abs(v0_down) / dec, v0_down * abs(v0_down) / (2.0 * dec)


# -- Painleve's rod -------------------------------------------------------------------------------
def painleve_effective_mass(theta: float, mu: float, slip_sign: float, m: float,
                            l: float) -> float:
    """A: the foot's normal acceleration per unit normal force, with sliding friction.

    A uniform rod of half-length l (I = m l^2 / 3) at the angle theta to the floor, its lower
    end (the foot) sliding, slip_sign = +1 when the foot slides toward the side the rod leans
    over (toward the point under the centre), -1 when away. In a frame whose x axis is the
    lean direction, the foot is at -l (cos theta, sin theta) from the centre; the contact force
    is (F, N) with F = -mu slip_sign N. Then m x'' = F, m y'' = N - m g and
    I theta'' = (foot - G) x (F, N) = l (F sin theta - N cos theta). The foot's height
    y - l sin theta has the acceleration y'' - l cos theta theta'' + l sin theta theta'^2, whose
    coefficient of N is

        A = 1/m + (l^2 cos theta / I) (cos theta + mu slip_sign sin theta)
          = (1 + 3 cos^2 theta + 3 mu slip_sign sin theta cos theta) / m.
    """
    c, s = np.cos(theta), np.sin(theta)
    inertia = m * l * l / 3.0
    return float(1.0 / m + l * l * c * (c + mu * slip_sign * s) / inertia)


def painleve_critical_mu(theta: float) -> float:
    """The mu above which A < 0 for a foot sliding away from the lean: (1 + 3 c^2)/(3 s c).

    Its minimum over theta is 4/3, at tan theta = 2.
    """
    c, s = np.cos(theta), np.sin(theta)
    return float((1.0 + 3.0 * c * c) / (3.0 * s * c))
