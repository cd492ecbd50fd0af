#!/usr/bin/env python3
"""The Panda from its URDF, in Python: eomgen.build() compiles its kernels once (cached after),
a computed-torque controller tracks a joint trajectory at 1 kHz (eom::integrate between control
samples), and an ensemble of 200 arms with uncertain payloads drifts under the nominal gravity
compensation (eom::ensemble on threads). Plots to a PNG; prints timings.

    /usr/bin/python3 examples/python/panda_tracking.py [out.png]
"""

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))
import eomgen  # noqa: E402


def main(out: Path):
    start = time.perf_counter()
    panda = eomgen.build(urdf=ROOT / "models" / "robots" / "panda.urdf", frames=["panda_link8"])
    built = time.perf_counter() - start
    start = time.perf_counter()
    eomgen.build(urdf=ROOT / "models" / "robots" / "panda.urdf", frames=["panda_link8"])
    print(f"eomgen.build(panda): {built:.2f} s (this call), {1e3 * (time.perf_counter() - start):.2f} ms "
          f"when already imported; nq = {panda.nq}, np = {panda.np}, kernels: {', '.join(panda.kernels)}")

    # ---- Computed-torque tracking: u = ID(q, qd, qdd_d + Kd e' + Kp e), held for 1 ms ----
    q0 = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    amp = np.array([0.4, 0.3, 0.3, 0.4, 0.5, 0.4, 0.6])
    w = np.array([1.0, 1.3, 1.7, 1.1, 2.0, 1.5, 2.3]) * np.pi

    def desired(t):
        return q0 + amp * np.sin(w * t), amp * w * np.cos(w * t), -amp * w * w * np.sin(w * t)

    kp, kd, dt, t_end = 100.0, 20.0, 1e-3, 3.0
    steps = int(round(t_end / dt))
    x = np.concatenate([desired(0.0)[0] + 0.05, np.zeros(7)])  # 0.05 rad off on every joint
    times = np.arange(steps + 1) * dt
    states = np.empty((steps + 1, 14))
    states[0] = x
    start = time.perf_counter()
    for k in range(steps):
        t = times[k]
        qd_, vd, ad = desired(t)
        q, v = x[:7], x[7:]
        u = panda.inverse_dynamics(q, v, ad + kd * (vd - v) + kp * (qd_ - q))
        _, xs, status = panda.integrate(t, t + dt, x, u=u, method="dop853", rtol=1e-10, atol=1e-12)
        if status != "ok":
            raise RuntimeError(f"integration failed at t = {t}: {status}")
        x = xs[-1]
        states[k + 1] = x
    tracking = time.perf_counter() - start
    qd_all = np.array([desired(t)[0] for t in times])
    error = np.linalg.norm(states[:, :7] - qd_all, axis=1)
    flange, _ = panda.frame_placement("panda_link8", states[:, :7])  # one batch call: (steps + 1, 3)
    flange_d, _ = panda.frame_placement("panda_link8", qd_all)
    print(f"tracking: {steps} control steps in {tracking:.2f} s ({1e6 * tracking / steps:.0f} us per step: "
          f"inverse_dynamics + integrate over 1 ms); |e| {error[0]:.3f} -> {error[-1]:.2e} rad")

    # ---- Ensemble: 200 payloads (link 7 mass +-30 %), nominal gravity compensation held ----
    n = 200
    rng = np.random.default_rng(7)
    P = np.tile(panda.parameter_values, (n, 1))
    mass7 = panda.parameter_names.index("panda_link7_mass")
    P[:, mass7] *= 1 + rng.uniform(-0.3, 0.3, n)
    x0 = np.tile(np.concatenate([q0, np.zeros(7)]), (n, 1))
    x0[:, :7] += rng.normal(0, 0.01, (n, 7))
    u_hold = panda.potential_gradient(q0)  # exact for the nominal arm at q0
    t_eval = np.linspace(0, 2.0, 101)
    start = time.perf_counter()
    times_e, samples, status = panda.ensemble(0.0, 2.0, x0, u=u_hold, p=P, t_eval=t_eval, rtol=1e-9, atol=1e-11)
    ensemble_time = time.perf_counter() - start
    ok = sum(s == "ok" for s in status)
    heights, _ = panda.frame_placement("panda_link8", samples[:, :, :7].reshape(-1, 7))
    heights = heights[:, 2].reshape(n, len(t_eval))
    print(f"ensemble: {n} cases x 2 s (dop853, {panda.get_num_threads()} threads) in {ensemble_time:.2f} s, "
          f"{ok}/{n} ok; flange height after 2 s: {heights[:, -1].min():.3f} ... {heights[:, -1].max():.3f} m")

    # ---- Batch throughput ----
    Q = rng.uniform(-1, 1, (100_000, 7))
    start = time.perf_counter()
    panda.forward_dynamics(Q, np.zeros(7))
    batch = time.perf_counter() - start
    print(f"forward_dynamics over 100000 states: {1e3 * batch:.1f} ms ({1e9 * batch / 1e5:.0f} ns per state)")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    for j in (0, 1, 3, 6):
        line, = ax[0, 0].plot(times, states[:, j], label=f"joint {j + 1}")
        ax[0, 0].plot(times, qd_all[:, j], "--", color=line.get_color(), lw=0.8)
    ax[0, 0].set(title="Computed torque: joints (dashed: desired)", xlabel="t [s]", ylabel="q [rad]")
    ax[0, 0].legend(fontsize=8)
    ax[0, 1].semilogy(times, error)
    ax[0, 1].set(title="Tracking error |q - q_d|", xlabel="t [s]", ylabel="rad")
    ax[1, 0].plot(flange_d[:, 0], flange_d[:, 2], "--", label="desired")
    ax[1, 0].plot(flange[:, 0], flange[:, 2], label="tracked")
    ax[1, 0].set(title="Flange path (panda_link8), x-z", xlabel="x [m]", ylabel="z [m]")
    ax[1, 0].axis("equal")
    ax[1, 0].legend(fontsize=8)
    for c in range(n):
        ax[1, 1].plot(t_eval, heights[c], color="tab:blue", lw=0.4, alpha=0.3)
    ax[1, 1].plot(t_eval, heights.mean(axis=0), color="k", lw=1.5, label="mean")
    ax[1, 1].set(title=f"Ensemble: {n} payloads (link 7 mass +-30 %), nominal gravity compensation",
                 xlabel="t [s]", ylabel="flange height [m]")
    ax[1, 1].title.set_fontsize(9)
    ax[1, 1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"plot: {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("panda_python.png"))
