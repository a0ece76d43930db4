"""PhaseONet: a fast operator that predicts the orbit's shape in phase, not in time.

Released at rest at q = 0 with E = V0, the particle runs to q = 1 and back with period

    T[V] = 2 ∫_0^1 dq / sqrt(2 (V0 − V(q))),

and the trajectory is even in time and T-periodic: q(t) = Q(h), p(t) = ±P(h) with the
half-phase h = min(u, 1 − u), u = (t / T) mod 1, and the sign + while u ≤ 1/2. So the
network never has to learn a frequency: the period comes from a quadrature of the
sensor spline (a fixed linear map of the sensors, then 1/sqrt and a weighted sum, in
float64), and a branch MLP predicts Q and P on a uniform grid of the half-phase
[0, 1/2]. A 4-point Lagrange stencil reads them off at the asked times.
"""

import math

import numpy as np
import torch

from ._layers import OperatorNet
from ._orbit import SensorSpline, composite_rule, invert_rows, orbit
from ._orbit_shape import edge_tables, shape_table

__all__ = ["PhaseONet", "period_quadrature"]

V0 = 2.0


def _spline_matrix(x_nodes, n_sensors):
    """(len(x_nodes), n_sensors): the not-a-knot cubic spline of values on the uniform
    sensor grid, evaluated at ``x_nodes`` (a linear map of the values)."""
    from scipy.interpolate import CubicSpline  # construction only

    sensors = np.linspace(0.0, 1.0, n_sensors)
    return CubicSpline(sensors, np.eye(n_sensors), axis=0)(x_nodes)


def period_quadrature(n_sensors=100, nodes=64):
    """The period T[V] as a linear map followed by a weighted sum of 1/sqrt.

    With q = (1 − cos πs)/2 the end-point singularities of 1/sqrt(V0 − V) cancel
    (V0 − V ≈ −V'(0) q near the wall at 0, dq/ds ∝ sin πs), and Gauss–Legendre in s converges
    fast: T = 2 Σ_k w_k / sqrt(2 (S (V0 − V_sensors))_k).

    Args:
        n_sensors: sensor count m (uniform on [0, 1]).
        nodes: Gauss–Legendre nodes (default 64; ``tests/models/test_phaseonet.py``
            checks the period against exact and independent ones).

    Returns:
        (S, w): S of shape (m, nodes) in float64, w of shape (nodes,) with the
        1/2 · (π/2) sin πs Jacobian folded in.
    """
    s, w = np.polynomial.legendre.leggauss(nodes)
    s, w = (s + 1) / 2, w / 2
    q = (1 - np.cos(np.pi * s)) / 2
    S = _spline_matrix(q, n_sensors).T
    return S, (math.pi / 2) * np.sin(np.pi * s) * w


class PhaseONet(OperatorNet):
    """Branch MLP over (V, log T) that predicts the half-orbit in a basis of the phase.

    The MLP's last layer gives ``basis`` coefficients per output; a trainable basis,
    initialised to the harmonics cos 2πmh (for q) and sin 2π(m+1)h (for p), turns them
    into values on a uniform grid of ``grid`` nodes over h ∈ [0, 1/2], read off at the
    asked phases by linear interpolation (two gathers and a lerp: few, cheap tensor
    operations, which is what a CPU pays for at batch 1,000).

    Cost per trajectory: one (m × nodes) float64 product for the period, an MLP of
    (m + 1)·width + (depth − 1)·width² + width·2·basis multiply-adds, 2·basis·grid for
    the basis, and O(1) per asked time and output. No trunk and no attention:
    predictions at different times are independent (``query_coupled`` False), and any
    t ≥ 0 is answered from the same periodic orbit (the phase error grows like
    t · δT / T).

    Args:
        width: hidden width of the branch MLP (default 128: at 1 thread and batch
            1,000 the MLP then costs about as much as the period and the read-out).
        depth: hidden layers (default 2).
        basis: coefficients per output (default 32).
        grid: nodes of the half-phase grid (default 256, ≥ 2; the linear
            interpolation's error is at most (1/(2·(grid − 1)))²/8 · max abs(Q'')).
        nodes: Gauss–Legendre nodes of the period quadrature (default 64).
        activation: "gelu" (default), "relu", "tanh" or "silu".
        n_sensors: length m of V (default 100).
        n_outputs: 2 (q and p; default) or 1 (q only, shape (B, M)).
        head: "phase" (default) as above; "time", the control of the ablation in
            ``benchmarks/cost/fast_operator.py``: the same network predicts q and p on a
            uniform grid of t ∈ [0, ``horizon``] (basis initialised to cos and sin of
            πmt/``horizon``) and the period is only an input feature (times past
            ``horizon`` take the last node's value).
        horizon: the time grid's end for ``head="time"`` (default 2).
        initial_state: False (default): released at rest at q = 0, as above. True: V
            carries (q0, p0) after the sensors, and the network works in the coordinates
            of the orbit through that state (:mod:`nh_operators.models._orbit`): turning
            points a < b, period T and starting phase u0 by quadrature and bisection of
            the sensor spline in float64; the MLP reads U = E − V at the ``nodes``
            quadrature points, scaled by its maximum (the orbit's shape in phase depends
            on U only up to a scale), and log T; and q = a + (b − a) Q(h),
            p = ± (b − a) / T · P(h) at the phase u = u0 + t / T. Q and P start at the
            harmonic orbit, (1 − cos 2πh)/2 and π sin 2πh. Phase head only.
        panels: with ``initial_state``, the period and the phase come from a composite
            Gauss–Legendre rule of ``panels`` × 16 nodes (default 32: an orbit just above
            a barrier passes its top slowly, a peak inside [a, b] that a single rule
            of 64 nodes resolves poorly; ``tests/models/test_phaseonet_states.py``
            checks the period 1e-4 above a barrier against adaptive quadrature).
        shape: where Q and P start: "learned" (default) from the harmonic orbit, the
            MLP learning the whole shape; "quadrature" from the shape computed by
            inverting the phase integral on the rule of the period (with
            ``initial_state`` the composite rule, at rest the ``nodes`` Gauss–Legendre
            nodes; :mod:`nh_operators.models._orbit_shape`: a classical solve of the
            orbit in the sensor spline), the MLP learning a correction that starts at
            zero (its last layer is zero at construction). Phase head, q and p only.

    Input ``(V, t)``: V (B, m) with V0 at both walls and V < V0 inside (the network
    clamps V0 − V at 1e-12; out-of-domain input is the domain check's job), or
    (B, m + 2) with ``initial_state``; t (M, 1). Output (B, M, n_outputs).

    Example:
        >>> import torch
        >>> net = PhaseONet(width=32, depth=1, basis=8, grid=16)
        >>> V = 8 * (torch.linspace(0, 1, 100) - 0.5) ** 2
        >>> net((V[None], torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([1, 7, 2])
    """

    query_coupled = False

    def __init__(self, width=128, depth=2, basis=32, grid=256, nodes=64, activation="gelu",
                 n_sensors=100, n_outputs=2, head="phase", horizon=2.0, initial_state=False,
                 panels=32, shape="learned"):
        super().__init__()
        if shape not in ("learned", "quadrature"):
            raise ValueError(f"shape must be 'learned' or 'quadrature', got {shape!r}")
        if shape == "quadrature" and (head != "phase" or n_outputs != 2):
            raise ValueError("shape='quadrature' needs head='phase' and n_outputs=2 (it "
                             "inverts the phase integral of the orbit)")
        self.shape = shape
        if head not in ("phase", "time"):
            raise ValueError(f"head must be 'phase' or 'time', got {head!r}")
        if initial_state and (head != "phase" or n_outputs != 2):
            raise ValueError("initial_state=True needs head='phase' and n_outputs=2 (the "
                             "orbit's phase gives the sign of p)")
        self.initial_state = bool(initial_state)
        if grid < 2 or basis < 1 or depth < 1 or width < 1:
            raise ValueError(f"need grid ≥ 2 and positive basis, depth and width; got "
                             f"grid={grid}, basis={basis}, depth={depth}, width={width}")
        acts = {"gelu": torch.nn.GELU, "relu": torch.nn.ReLU, "tanh": torch.nn.Tanh,
                "silu": torch.nn.SiLU}
        if activation not in acts:
            raise ValueError(f"unknown activation {activation!r}; choose from {sorted(acts)}")
        if n_outputs not in (1, 2):
            raise ValueError(f"n_outputs must be 1 or 2, got {n_outputs}")
        self.head, self.horizon = head, float(horizon)
        self.n_sensors, self.n_outputs, self.grid = n_sensors, n_outputs, grid
        S, w = period_quadrature(n_sensors, nodes)
        # float64 whatever the network's dtype (cast_network would round buffers), and
        # not in the state_dict: 2 (V0 − V) S = bias − V (2S), one addmm.
        self._quadrature = {}
        self._quad_cpu = (torch.tensor(V0 * 2 * S.sum(0)), torch.tensor(-2 * S),
                          torch.tensor(w))
        s, gw = np.polynomial.legendre.leggauss(nodes)   # the same rule's nodes in s
        self._gauss = (torch.tensor((s + 1) / 2), torch.tensor(gw / 2),
                       torch.tensor((math.pi / 2) * np.sin(np.pi * (s + 1) / 2)))
        # Grid coordinate: the half-phase h ∈ [0, 1/2] (or t / horizon ∈ [0, 1]).
        h = np.linspace(0.0, 0.5, grid) if head == "phase" else np.linspace(0, 1, grid)
        angle = 2 * np.pi * h if head == "phase" else np.pi * h
        m = np.arange(basis)[:, None]
        harmonics = np.stack([np.cos(m * angle), np.sin((m + 1) * angle)])[:n_outputs]
        self.basis = torch.nn.Parameter(torch.tensor(harmonics, dtype=torch.float32))
        # Q starts at the harmonic orbit (1 − cos 2πh)/2, its correction scaled by 0.1
        # so that the first steps do not swamp it; P starts at zero.
        base = (1 - np.cos(angle)) / 2 if head == "phase" else np.zeros(grid)
        speed = np.pi * np.sin(angle) if self.initial_state else np.zeros(grid)
        shift = np.stack([base, speed])[:n_outputs, None, :]   # (k, 1, grid)
        self.register_buffer("out_shift", torch.tensor(shift, dtype=torch.float32),
                             persistent=False)
        self.register_buffer("out_scale", torch.tensor([0.1, 1.0])[:n_outputs, None, None],
                             persistent=False)
        layers, d = [], (nodes if self.initial_state else n_sensors) + 1
        if self.initial_state:
            s, w = np.polynomial.legendre.leggauss(nodes)
            self._nodes = (torch.tensor((s + 1) / 2), torch.tensor(w / 2))
            self._spline = SensorSpline(n_sensors)
            self._rule = composite_rule(panels, 16)
        for _ in range(depth):
            layers += [torch.nn.Linear(d, width), acts[activation]()]
            d = width
        layers.append(torch.nn.Linear(d, n_outputs * basis))
        if shape == "quadrature":   # start at the computed shape
            torch.nn.init.zeros_(layers[-1].weight)
            torch.nn.init.zeros_(layers[-1].bias)
        self.branch = torch.nn.Sequential(*layers)

    def period(self, V):
        """T[V] of the sensor spline, shape (B,), float64."""
        if V.device not in self._quadrature:
            self._quadrature[V.device] = tuple(a.to(V.device) for a in self._quad_cpu)
        bias, matrix, weights = self._quadrature[V.device]
        squared_speed = torch.addmm(bias, V.to(torch.float64), matrix).clamp_(min=2e-12)
        return torch.rsqrt_(squared_speed) @ (2 * weights)

    def rest_shape(self, V):
        """The rest orbit's period T (B,) and computed shape, Q and abs(p) (B, grid), on the
        grid of the half-phase, float64 (``shape="quadrature"`` at rest): the period's own
        rule (``nodes`` Gauss–Legendre nodes) read backwards (``_orbit_shape``)."""
        if V.device not in self._quadrature:
            self._quadrature[V.device] = tuple(a.to(V.device) for a in self._quad_cpu)
        bias, matrix, _ = self._quadrature[V.device]
        s, w, jac = (a.to(V.device) for a in self._gauss)
        squared_speed = torch.addmm(bias, V.to(torch.float64), matrix).clamp_(min=2e-12)
        f = jac * torch.rsqrt_(squared_speed)
        T = 2 * (f @ w)
        if V.device.type == "cpu" and not (torch.is_grad_enabled() and V.requires_grad):
            Q, P = (torch.from_numpy(a) for a in invert_rows(
                f.numpy(), s.numpy(), w.numpy(), T.numpy(),
                *edge_tables(s.numpy(), w.numpy()), self.grid))
        else:
            Q, P = shape_table(f, s, w, T, self.grid)
        return T, Q, P / T[:, None]

    def state_orbit(self, V):
        """The orbit through each row's state (``initial_state`` networks): a dict of
        float64 tensors a, b, E, T, u0 (B,) and U (B, nodes) (:func:`_orbit.orbit`)."""
        sensors, state = self._sensors_and_state(V.to(torch.float64))
        s, w = (a.to(V.device) for a in self._nodes)
        rule = tuple(a.to(V.device) for a in self._rule)
        return orbit(self._spline, sensors, state[:, 0], state[:, 1], s, w, rule=rule,
                     shape_grid=self.grid if self.shape == "quadrature" else 0)

    def _forward(self, V, t):
        if self.initial_state:
            o = self.state_orbit(V)
            T, shape = o["T"], o["U"] / o["U"].amax(1, keepdim=True)
            x = torch.cat([shape, torch.log(T)[:, None]], dim=1).to(V.dtype)
        else:
            if self.shape == "quadrature":
                T, *computed = self.rest_shape(V)
            else:
                T = self.period(V)
            x = torch.cat([(V0 - V) / 2, torch.log(T).to(V.dtype)[:, None]], dim=1)
        coeffs = self.branch(x)                                   # (B, k · basis)
        r = self.basis.shape[1]
        # Per output a plain 2-D product and 2-D gathers: contiguous operands are what
        # keeps this head cheap next to the MLP on a CPU.
        if self.shape == "quadrature":
            shift = [a.to(coeffs.dtype) for a in
                     ((o["Q"], o["P"]) if self.initial_state else computed)]
        else:
            shift = [s[0] for s in self.out_shift]
        shapes = [torch.addmm(shift[k], coeffs[:, k * r:(k + 1) * r],
                              self.basis[k] * self.out_scale[k, 0])
                  for k in range(self.n_outputs)]                 # each (B, grid)
        if self.head == "time":
            x = (t[:, 0] * ((self.grid - 1) / self.horizon)).to(coeffs.dtype)
            x, sign = x[None, :].expand(len(V), -1), None
        else:
            # Phase u = t/T mod 1 in float64 when a time is far enough for float32's
            # 6e-8 relative error to move the phase (|t| > 16).
            wide = (torch.float64 if self.initial_state or bool((t.abs() > 16).any())
                    else coeffs.dtype)
            d = torch.frac(torch.outer(torch.reciprocal(T).to(wide), t[:, 0].to(wide))
                           + (o["u0"][:, None] if self.initial_state else 0.0))
            d = d.sub_(0.5)                              # u − 1/2 ∈ [−1/2, 1/2)
            sign = torch.sign(d).neg_().to(coeffs.dtype)  # p changes sign at T/2
            # grid coordinate of the half-phase 1/2 − |u − 1/2|
            x = d.abs_().mul_(-2 * (self.grid - 1)).add_(self.grid - 1).to(coeffs.dtype)
        j = torch.floor(x).clamp_(0, self.grid - 2)
        weight = (x - j).clamp_(max=1)
        left = j.long()
        right = left + 1
        ys = [torch.lerp(torch.gather(g, 1, left), torch.gather(g, 1, right), weight)
              for g in shapes]
        if len(ys) == 2 and sign is not None:
            ys[1] = ys[1].mul_(sign) if not torch.is_grad_enabled() else ys[1] * sign
        if self.initial_state:   # orbit coordinates → q, p
            L = (o["b"] - o["a"]).to(coeffs.dtype)[:, None]
            ys = [o["a"].to(coeffs.dtype)[:, None] + L * ys[0],
                  ys[1] * (L / T.to(coeffs.dtype)[:, None])]
        return torch.stack(ys, dim=-1)
