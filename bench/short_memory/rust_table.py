"""Prints the Rust constants of estimator-core's `tail` module: the decay times
T_k (samples) and the table g_k(alpha), alpha = 0.05, 0.10, ..., 0.95, of the
scaled sum-of-exponentials coefficients c_k(alpha) = -(sin(pi a)/pi) s_k^(1+a) g_k(a),
s_k = 1/T_k, fitted (core.SOE) for the GL weights at lags >= 64.

    python3 bench/short_memory/rust_table.py
"""
import numpy as np
from core import SOE

MODES = 6

soe = SOE(64, MODES)
s_k = 1.0 / soe.T
grid = np.round(np.arange(0.05, 0.95 + 1e-9, 0.05), 6)
print("/// Decay times `T_k` of the modes (samples), geometric over 16…40 000.")
print("pub const DECAY_SAMPLES: [f64; MODES] = [" + ", ".join(repr(float(t)) for t in soe.T) + "];")
print("/// `r_k = e^(−1/T_k)`.")
print("pub const RATES: [f64; MODES] = [" + ", ".join(repr(float(np.exp(-1.0 / t))) for t in soe.T) + "];")
print("/// `ln s_k = −ln T_k`.")
print("const LN_S: [f64; MODES] = [" + ", ".join(repr(float(-np.log(t))) for t in soe.T) + "];")
print("/// `g_k(α)` at α = 0.05, 0.10, …, 0.95 (rows), `c_k = −(sin πα/π)·s_k^(1+α)·g_k`.")
print("const G_TABLE: [[f64; MODES]; ORDERS] = [")
for a in grid:
    scale = -(np.sin(np.pi * a) / np.pi) * s_k ** (1 + a)
    g = soe.coeffs(a) / scale
    print("    [" + ", ".join(repr(float(x)) for x in g) + "],")
print("];")
