#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""One fluid cell and its particles under hemocosim's serial coupling, as a linear map.

Fluid density rho, particles of mass M per volume with drag relaxation time tau, coupling
interval dt. Each interval the particles relax exactly towards the fluid velocity U they were
given; the fluid then takes minus their impulse J, with the implicit drag K (U' - U) and, if
`returned`, what that term kept back in the step before:

    v'                 = U + (v - U) e,               e = exp(-dt / tau)
    J                  = M (v' - v)
    (rho + K dt)(U' - U) = f dt - J + [returned] K dt (U - U_prev)

K dt = M dt / tau ("instantaneous", sum of beta) or M (1 - e) ("interval_response").
Prints the largest decaying eigenvalue and the steady mixture acceleration against the exact
f / (rho + M) (docs/design.md, Coupling numerics; history: docs/notes/performance-log.md, "the
implicit drag's added inertia").

With --forced: the coupled relaxation mode against the exact exp(-(dt/tau)(1 + M/rho)), and the
long-time diffusivity of particles driven by a random force (correlation time tc, held over
each DEM step of at most 2.5 tau, as contacts are), the fluid damped at rate gamma (its viscous
time), against the same at dt = 0.05 tau (an open question of docs/performance.md §6; history:
docs/notes/performance-log.md, "what moves D at short intervals").

With --contact: the particles held by a spring k (a contact lasting about half its period, as
the DEM's Hertz contacts do), the plasma damped at rate gamma; the particles move by velocity
Verlet with the exponential drag in DEM steps of at most 2.8 tau, as the DEM does, the fluid as
above. Prints the decay rate of the oscillation's energy against a reference at dt = 0.005 tau:
below 1 the exchange damps the contact less than it should, negative means it feeds it (the
dense-suspension limit of docs/performance.md §4 is the candidate).
"""
import sys
import numpy as np


def step_matrix(rho, M, tau, dt, k_dt, returned):
    e = np.exp(-dt / tau)
    c = 1.0 / (rho + k_dt)
    # state (U, U_prev, v)
    return np.array([
        [1 - c * M * (1 - e) + returned * c * k_dt, -returned * c * k_dt, c * M * (1 - e)],
        [1, 0, 0],
        [1 - e, 0, e],
    ])


def mixture_acceleration(rho, M, tau, dt, k_dt, returned, steps=4000, f=1.0):
    e = np.exp(-dt / tau)
    U = U_prev = v = 0.0
    for _ in range(steps):
        J = M * (1 - e) * (U - v)
        v = U * (1 - e) + v * e
        U, U_prev = U + (f * dt - J + returned * k_dt * (U - U_prev)) / (rho + k_dt), U
    return (U - U_prev) / dt * (rho + M) / f


def forced_diffusivity(M, tau, dt, gamma, tc, t_end=4000.0, realisations=64, fine=0.01):
    """Slope of the particles' mean squared displacement / 2 under a random force (rho = 1)."""
    rng = np.random.default_rng(1)  # the same force history for every dt: paired differences
    substeps = max(1, int(np.ceil(dt / 2.5)))
    h = dt / substeps
    decay, draws = np.exp(-fine / tc), max(1, int(round(h / fine)))
    U, v, x, R = (np.zeros(realisations) for _ in range(4))
    force = rng.normal(size=realisations)
    k_dt = M * (1 - np.exp(-dt / tau))
    steps = int(t_end / dt)
    msd = np.empty(steps)
    for n in range(steps):
        v0, impulse = v.copy(), np.zeros(realisations)
        for _ in range(substeps):
            terminal, e = U + force * tau / M, np.exp(-h / tau)
            x += terminal * h + (v - terminal) * tau * (1 - e)
            v = terminal + (v - terminal) * e
            impulse += force * h
            for _ in range(draws):
                force = decay * force + np.sqrt(1 - decay**2) * rng.normal(size=realisations)
        J = M * (v - v0) - impulse  # the drag impulse on the particles
        U_new = (U - J + k_dt * U + R * dt) / (1 + k_dt + gamma * dt)
        R, U = k_dt / dt * (U_new - U), U_new
        msd[n] = np.mean(x**2)
    t = dt * np.arange(1, steps + 1)
    return np.polyfit(t[steps // 2:], msd[steps // 2:], 1)[0] / 2


def print_forced(M=1.6, gamma=0.04, tc=10.0):
    print(f"M/rho = {M}, fluid damping {gamma}/tau, force correlation {tc} tau")
    print("dt/tau  relaxation |z|  exact    D / D(dt = 0.05 tau)")
    reference = forced_diffusivity(M, 1.0, 0.05, gamma, tc)
    for dt in (0.1, 0.5, 1.25, 2.5, 5.0, 20.0):
        z = sorted(abs(np.linalg.eigvals(step_matrix(1.0, M, 1.0, dt, M * (1 - np.exp(-dt)), 1))))[-2]
        d = forced_diffusivity(M, 1.0, dt, gamma, tc)
        print(f"{dt:6.2f}  {z:14.4f}  {np.exp(-dt * (1 + M)):.4f}   {d / reference:.3f}")


def contact_energy_decay(M, k, gamma, dt, k_dt_of, returned=1.0, t_end=80.0, dem_step_max=2.8):
    """Decay rate of the energy of particles on a spring k in one fluid cell (rho = tau = 1)."""
    substeps = max(1, int(np.ceil(dt / dem_step_max - 1e-9)))
    h = dt / substeps
    r = (1 - np.exp(-h)) / h  # the exponential drag's ratio over one DEM step (beta = M)
    k_dt = k_dt_of(M, dt)
    U = x = R = 0.0
    w, f_last = 1.0, None  # w: the particles' half-step velocity; f_last: the last drag force
    energy = []
    for _ in range(int(t_end / dt)):
        J = 0.0  # the drag impulse on the particles over the interval (Verlet-weighted)
        for _ in range(substeps):
            x += h * w
            f_other = -k * x
            f_drag = r * M * (U - w) + (r - 1) * f_other
            f_last = f_drag if f_last is None else f_last
            w += h * (f_drag + f_other) / M
            J += h / 2 * (f_last + f_drag)
            f_last = f_drag
        U_new = ((1 + k_dt) * U - J + returned * R * dt) / (1 + k_dt + gamma * dt)
        R, U = k_dt / dt * (U_new - U), U_new
        energy.append(0.5 * M * w * w + 0.5 * k * x * x + 0.5 * U * U)
    t = dt * np.arange(1, len(energy) + 1)
    late = t > t_end / 3
    return -np.polyfit(t[late], np.log(np.array(energy)[late] + 1e-300), 1)[0]


def print_contact(gamma=0.4):
    schemes = (("interval_response, returned", lambda M, dt: M * (1 - np.exp(-dt)), 1.0),
               ("interval_response", lambda M, dt: M * (1 - np.exp(-dt)), 0.0),
               ("instantaneous", lambda M, dt: M * dt, 0.0))
    ratios = (0.156, 0.3125, 0.625, 1.25, 2.5, 5.0, 20.0)
    print(f"plasma damping {gamma}/tau, spring k = 0.14 M (half period ~ 8 tau); energy decay / reference at dt/tau:")
    print(f"{'M/rho':>5s}  {'scheme':28s}" + "".join(f"{r:>8g}" for r in ratios))
    for M in (1.6, 4.0, 7.0):
        k = 0.14 * M
        reference = contact_energy_decay(M, k, gamma, 0.005, schemes[0][1])
        for name, k_dt_of, returned in schemes:
            rates = [contact_energy_decay(M, k, gamma, dt, k_dt_of, returned) / reference for dt in ratios]
            print(f"{M:5.1f}  {name:28s}" + "".join(f"{q:8.2f}" for q in rates))


if __name__ == "__main__" and "--forced" in sys.argv:
    print_forced()
elif __name__ == "__main__" and "--contact" in sys.argv:
    print_contact()
elif __name__ == "__main__":
    print("K              returned  M/rho  dt/tau  slow |z|  acceleration x (rho+M)/f")
    for name, returned in (("instantaneous", 0), ("interval_resp.", 0), ("interval_resp.", 1)):
        for m in (0.1, 1.6, 10.0):
            for ratio in (0.01, 1.0, 19.0, 100.0):
                k_dt = m * ratio if name == "instantaneous" else m * (1 - np.exp(-ratio))
                z = sorted(abs(np.linalg.eigvals(step_matrix(1.0, m, 1.0, ratio, k_dt, returned))))[-2]
                a = mixture_acceleration(1.0, m, 1.0, ratio, k_dt, returned)
                print(f"{name:14s} {returned:8d}  {m:5.1f}  {ratio:6.2f}  {z:8.4f}  {a:.4f}")
