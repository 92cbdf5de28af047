"""The 2006 paper's mass-spring model driven from Python: its small cloth (289 vertices, 512 faces,
unit masses, g_ij = k (1 - l_ij / l'_ij) d_ij), pulled by a pinch event by event, with the force
fed back checked against the paper's equations 1-3 computed here in NumPy."""
import numpy as np
import pytest

import kiji

K = 100.0        # the spring constant k of eq. 3, N/m
HAND = 20.0      # the pinch's spring from the pen to the grabbed vertex, N/m
SUBSTEPS = 10
FRAME_RATE = 60.0


def paper_session(gamma):
    s = kiji.Session(frame_rate=FRAME_RATE)
    g = s.add_garment(kiji.rectangle(0.8, 0.8, nx=17, ny=17))
    # Only the pen's force acts (eq. 2): no gravity, no body, nothing asleep.
    s.solver_params = kiji.SolverParams(model="mass_spring", spring_k=K, spring_damping=gamma, gravity=(0, 0, 0),
                                        substeps=SUBSTEPS, sleep_after=0.0, body_collision=False,
                                        self_collision=False)
    x = g.positions
    corners = [int(np.argmin(((x[:, :2] - c) ** 2).sum(1))) for c in ((0, 0), (0.8, 0), (0, 0.8), (0.8, 0.8))]
    pins = np.zeros(len(x), bool)
    pins[corners] = True
    g.pins = pins  # the cloth held at its corners, as on a frame
    return s, g


def spring_forces(x, edges, rest, k):
    """Eq. 3 summed over each vertex's neighbours: sum_j g_ij, g_ij = k (1 - l_ij / l'_ij) d_ij."""
    d = x[edges[:, 1]] - x[edges[:, 0]]
    length = np.linalg.norm(d, axis=1)  # l'_ij
    gij = (k * (1.0 - rest / length) / length)[:, None] * d
    f = np.zeros_like(x)
    np.add.at(f, edges[:, 0], gij)
    np.add.at(f, edges[:, 1], -gij)
    return f


def step(x, v, free, edges, rest, grabbed, target, gamma):
    """One frame of eqs. 1-2 with unit masses (1 x_i'' = -gamma x_i' + sum_j g_ij + f_i), f on the
    grabbed vertex being the pen's spring HAND (target - x), integrated as the solver documents it:
    symplectic Euler over the substeps."""
    h = 1.0 / FRAME_RATE / SUBSTEPS
    for _ in range(SUBSTEPS):
        f = spring_forces(x, edges, rest, K)
        f[grabbed] += HAND * (target - x[grabbed])
        a = f - gamma * v
        v = np.where(free[:, None], v + h * a, v)
        x = np.where(free[:, None], x + h * v, x)
    return x, v


@pytest.mark.parametrize("gamma", [0.0, 2.0])  # the paper's eq. 2 (no damping), and eq. 1 with damping
def test_a_pinch_driven_event_by_event_feeds_back_the_force_of_the_papers_equations(gamma):
    s, g = paper_session(gamma)
    assert (g.vertex_count, g.face_count) == (289, 512)  # the paper's V = 289, P = 512
    x0 = g.positions
    centre = int(np.argmin(((x0[:, :2] - (0.4, 0.4)) ** 2).sum(1)))
    edges, rest, free = g.edges, g.rest_lengths, ~g.pins

    # The pen touches the centre vertex and the button goes down: grab_radius 0 takes that vertex
    # alone, as the paper's pinch does.
    pen = x0[centre].copy()
    first = s.begin("pinch", kiji.ToolEvent("begin", pen, time=s.time), stiffness=HAND, grab_radius=0.0)
    np.testing.assert_allclose(first.force, 0.0, atol=1e-12)

    x, v = x0.copy(), np.zeros_like(x0)
    feedback = []
    for i in range(1, 41):
        target = pen.copy()  # the hand's spring holds this point during the step to the event's time
        pen = pen + (0.0, 0.0, 0.003)  # the pen rises 3 mm a frame: 12 cm in all
        f = s.update(kiji.ToolEvent("move", pen, time=i / FRAME_RATE))
        assert s.steps == i  # each event a frame later steps the cloth once
        x, v = step(x, v, free, edges, rest, centre, target, gamma)
        np.testing.assert_allclose(g.positions, x, rtol=0, atol=1e-9)
        # The force on the hand: the pen's spring, pulling it back towards the vertex it holds; on the
        # vertex it is f_Phantom of eq. 2, the same force the other way.
        expected = HAND * (x[centre] - pen)
        np.testing.assert_allclose(f.force, expected, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(f.torque, 0.0)
        feedback.append(f.force)
    s.end(kiji.ToolEvent("end", pen, time=s.time))

    # The cloth pulls the hand down (towards the cloth), harder as the pen rises.
    fz = np.array(feedback)[:, 2]
    assert fz[-1] < -0.1 and fz[-1] < fz[0]
    # The springs of eq. 3 as the solver computes them, against NumPy's.
    np.testing.assert_allclose(s.solver(0).spring_forces(), spring_forces(g.positions, edges, rest, K), atol=1e-9)


def test_at_rest_the_hand_feels_the_springs_of_eq_3_on_the_vertex_it_holds():
    # Eq. 1 with damping settles: then 0 = sum_j g_ij + f_Phantom at the grabbed vertex, so the force fed
    # back (-f_Phantom) is the pull of its springs, computed from the positions alone.
    s, g = paper_session(gamma=1.0)
    x0 = g.positions
    centre = int(np.argmin(((x0[:, :2] - (0.4, 0.4)) ** 2).sum(1)))
    pen = x0[centre].copy()
    s.begin("pinch", pen, stiffness=HAND, grab_radius=0.0)
    lifted = pen + (0.0, 0.0, 0.1)
    s.update(kiji.ToolEvent("move", lifted, time=s.time))
    s.advance_to(40.0)  # held 10 cm above the cloth for 40 s
    f = s.update(lifted)  # the same place, now: no further step
    x = g.positions
    assert np.abs(g.velocities).max() < 1e-4  # at rest
    pull = spring_forces(x, g.edges, g.rest_lengths, K)[centre]
    np.testing.assert_allclose(f.force, pull, rtol=1e-4, atol=1e-9)
    assert f.force[2] < -0.5  # the stretched cloth pulls the hand down
    s.cancel()
    np.testing.assert_array_equal(g.positions, x0)  # cancelled: the cloth as it was
