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
f / (rho + M) (docs/performance.md, "the implicit drag's added inertia").
"""
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


if __name__ == "__main__":
    print("K              returned  M/rho  dt/tau  slow |z|  acceleration x (rho+M)/f")
    for name, returned in (("instantaneous", 0), ("interval_resp.", 0), ("interval_resp.", 1)):
        for m in (0.1, 1.6, 10.0):
            for ratio in (0.01, 1.0, 19.0, 100.0):
                k_dt = m * ratio if name == "instantaneous" else m * (1 - np.exp(-ratio))
                z = sorted(abs(np.linalg.eigvals(step_matrix(1.0, m, 1.0, ratio, k_dt, returned))))[-2]
                a = mixture_acceleration(1.0, m, 1.0, ratio, k_dt, returned)
                print(f"{name:14s} {returned:8d}  {m:5.1f}  {ratio:6.2f}  {z:8.4f}  {a:.4f}")
