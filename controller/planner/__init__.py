"""The planner: moves -> :class:`Plan`, a jerk-limited reference that follows the program.

Entry point: :func:`plan` (moves, machine) -> :class:`Plan`; ``Plan.sample(period_s)`` gives the
servo's reference. Units: mm, s (speeds mm/s, accelerations mm/s^2, jerks mm/s^3).

The steps, in the order :func:`plan` runs them (module: its one job):

0. ``path_stream``    path control (G61, G61.1, G64 P Q), made as the moves come: the moves
   ``blend``          with length and their stops, G64 Q's merge (``path_control``: each
   ``corner_blend``   move's mode and the merge), blend arcs at corners (``blend``;
                      ``corner_blend``: corners that involve an arc), a stretch at a time into
                      lists kept on disk; ``limit_events``: Marlin's M201-M205, planned part
                      by part
   ``transition``     G2 transitions (quintic curves) at G64 tangent junctions whose curvature
                      jumps: where, how long, their deviation measured
1. ``travel``         refuse moves that leave the machine's travel (arcs: their quadrant points)
2. ``segment``        arcs -> chord vertices ("chord": grbl's sagitta rule, "fixed": Marlin's)
3. ``move_geometry``  per move: vertices, end tangents and curvatures, its 1-D limits
   ``limits``         (leaf) what a move may do: BlockLimits, FollowGeometry, the curvature caps,
                      the arcs' limits in vectorised batches; ``spline_geometry``: a spline
                      taken as a curve by its arc-length fraction; ``transition_geometry``: a
                      transition's chords, points and derivatives (many at once)
4. ``junctions``      speed caps and JunctionStates between moves; caps the pieces can take
5. ``chains``         runs of moves planned as one 1-D profile (their junctions do not bind)
   ``lookahead``      backward and forward passes over the chains -> the junction speeds
6. ``ruckig_solver``  the only ruckig import: the 1-D profile per chain, the 3-DoF pieces
   ``profile``        Profile1D, the 1-D profile (dur, s, v, a, j per phase) every step hands on
   ``knots``          (leaf) break points merged: the sorted union of two sets of times or fractions
   ``speedup``        faster 1-D candidates for arcs that ramp, checked point by point
   ``saturated_ramp`` time-optimal-like ramps on small arcs from rest (a speedup candidate)
   ``ramp_bounds``    the jerk and acceleration those ramps may use, per state
7. ``arc_states``     exact arc states where the profile passes the vertices (``arc_batch``:
                      many arcs at once, bit for bit as one by one)
   ``jerk3``          closed-form constant-jerk pieces between those states, and their limit check
   ``pieces``         profile -> the reference's phases: straight moves projected, arc pieces
                      by jerk3 or (where they break a limit) by the solver
8. ``rounds``         the re-planning rounds (a piece that leaves the arc next to a moving
                      junction lowers that junction; only the chains whose ends changed are
                      planned again); ``chain_plan`` / ``chain_prep``: a round's chains in
                      vectorised batches
   ``stop_overlap``   G64 stops between straight moves: the two moves' profiles overlapped
                      (``overlap_search``: the longest overlap that keeps every limit and P)
   ``windows``        a long program planned a window of moves at a time (``window_cut``:
                      where a window is cut, and which comes next; ``window_prep``: a window
                      prepared; ``window_ahead``: the next windows prepared, and their first
                      round planned, by the other processes; ``window_judge``: slow blends
                      judged window by window)
   ``plan``           the orchestration: path control, geometry, junctions, rounds -> Plan
9. ``cubic``          constant-jerk phases per axis, sampled vectorised
   ``segmented_curve`` the plan's reference held as the planner's segments, laid out by block
   ``result``         Plan, the frozen result, and its sampling at the servo period
   ``vertices``       the programmed moves' chord vertices, made when read

Imports run one way: ``limits``, ``profile`` and ``knots`` are leaves; ``move_geometry`` uses ``limits`` and
``segment``; ``junctions``, ``speedup``, ``arc_states`` and ``pieces`` use ``move_geometry``;
``plan`` uses them all. Parsing and planning run with the cyclic garbage collector paused
(:mod:`gantry_sim.controller.gc_pause`).
"""

from gantry_sim.controller.planner.plan import plan
from gantry_sim.controller.planner.result import Plan

__all__ = ["Plan", "plan"]
