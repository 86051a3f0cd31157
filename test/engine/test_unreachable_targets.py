"""A target out of reach is refused in bounded work: it runs on the node's command thread, and
each such refusal held ~/command for 1.7-5.6 s (an outside adversary: three unreachable loader
targets delayed a command by 13 s).

Where the time went, and what is measured here instead of time (a timed unit test would be
noise on a shared machine):
* the 16 in-mode restarts (Newton walks from elsewhere in the mode) each walked into a fold:
  the failed ones may now spend RESTART_BUDGET max_iter between them (they cannot be skipped:
  a walk stalled in a local least-squares minimum reads "cannot assemble" too, and a start
  elsewhere places such a target: 3 of 100 random loader targets, an outside adversary);
* every failed walk of the target's search measured its nearest configuration's miss (a
  least-squares search, ~0.1 s on the excavator) for a reason nobody read: only the refusal
  the client gets measures it now (Effort.UNEXPLAINED);
* the reach edge bisected 40 times, each probe a walk from the current configuration halving
  its step ten times past the fold: it now marches from the last value reached, each probe
  one direct Newton solve (Effort.DIRECT), and finds the same edge.

Oracles: the edge a refusal quotes is where the solver's full walks (not the march's probes)
stop: reached just inside it, not 1e-4 of the way beyond."""

from __future__ import annotations

import math
import re

import pytest
from scenes import load

from linkage_ros.core.newton import system as newton_system
from linkage_ros.core.solver import Effort, Solver, mode_rule
from linkage_ros.engine import Engine, EngineSettings


@pytest.fixture
def counted(monkeypatch):
    """Counts of the least-squares miss searches, the restarts and each Effort's solves."""
    counts = {'least_miss': 0, 'restarts': 0, Effort.FULL: 0, Effort.UNEXPLAINED: 0}
    counts[Effort.DIRECT] = 0
    counts['restart_iterations'] = 0
    inside = []
    least_miss = newton_system.LoopSystem.least_miss
    multi_start = mode_rule.ModeKeeper.multi_start
    solve = Solver.solve

    def count_least_miss(self, *a, **k):
        counts['least_miss'] += 1
        return least_miss(self, *a, **k)

    def count_restarts(self, *a, **k):
        counts['restarts'] += 1
        inside.append(True)
        try:
            return multi_start(self, *a, **k)
        finally:
            inside.pop()

    def count_solve(self, values, commit=True, effort=Effort.FULL, **kw):
        counts[effort] += 1
        r = solve(self, values, commit, effort, **kw)
        if inside and not r.success:
            counts['restart_iterations'] += r.iterations
        return r

    monkeypatch.setattr(newton_system.LoopSystem, 'least_miss', count_least_miss)
    monkeypatch.setattr(mode_rule.ModeKeeper, 'multi_start', count_restarts)
    monkeypatch.setattr(Solver, 'solve', count_solve)
    return counts


@pytest.mark.parametrize(
    ('scene', 'target'),
    [
        ('front_loader', {'D.x': 10.0, 'bin': 2.0}),
        ('excavator', {'K.x': 0.7, 'bucket': 0.6, 'Z1': 1.5}),
    ],
)
def test_an_unreachable_target_is_refused_in_bounded_work(counted, scene, target):
    mech = load(scene)
    engine = Engine(mech, EngineSettings())
    here = engine.last
    before = dict(here.inputs)
    for k in list(counted):
        counted[k] = 0
    r = engine.target(target)
    assert not r.success
    name = next(iter(target))
    others = ', '.join(list(target)[1:])
    assert r.reason.startswith(
        f'{name} = {target[name]:g} m with {others} as given is out of reach'
    )
    # the edge it quotes is where full walks stop: the fraction of the way it gives, every known
    # moved together from the current configuration (a link's angle the short way round), is
    # reached less a rounding of its 6 digits, and 1e-4 of the way beyond it is not
    frac = float(re.search(r'reachable (\S+) of the way', r.reason).group(1))
    quoted = float(re.search(rf'up to {re.escape(name)} = (\S+) m', r.reason).group(1))

    def command(s):
        out = {}
        for k, v in target.items():
            if k in here.links:  # an angle, the short way round
                now, step = here.links[k], math.remainder(v - here.links[k], 2 * math.pi)
            else:  # a coordinate or an actuator's throw (m)
                now = here.points[name[0]][0] if k == name else here.inputs[k]
                step = v - now
            out[k] = now + s * step
        return out

    assert command(frac)[name] == pytest.approx(quoted, rel=1e-5)
    for s, reached in ((frac - 1e-6, True), (frac + 1e-4, False)):
        fresh = Solver(mech, knowns=list(target))
        fresh.adopt(here)
        assert fresh.solve(command(s), commit=False).success is reached, s
    assert 'misses closing by' in r.reason  # the one measured refusal
    assert counted['least_miss'] == 1
    assert counted['restarts'] <= 1
    # the march's direct probes
    # the failed restarts within their budget (the last one may overrun it by one walk, at most
    # ten halvings of up to max_iter each)
    max_iter = EngineSettings().max_iterations
    assert counted['restart_iterations'] <= (mode_rule.RESTART_BUDGET + 11) * max_iter
    assert 10 <= counted[Effort.DIRECT] <= 200
    assert engine.last.inputs == before  # a refusal changes nothing


def test_the_marchs_edge_is_where_full_walks_stop():
    """The loader's D.x target with its bin held where it is: the march's edge (the last value
    its probes reached) is reached by a full continuation walk from the drawing, and a step of
    1e-4 of the way beyond it is not."""
    from linkage_ros.core.solver.reach import reach_edge

    mech = load('front_loader')
    engine = Engine(mech, EngineSettings())
    here = engine.last
    solver = Solver(mech, knowns=['D.x', 'bin'])
    solver.adopt(here)
    bin_now = here.links['bin']
    edge = reach_edge(solver, {'D.x': 10.0, 'bin': bin_now}, here)
    assert edge is not None and edge.coordinate == 'D.x'
    at = edge.edge[0]
    fresh = Solver(mech, knowns=['D.x', 'bin'])
    fresh.adopt(here)
    assert fresh.solve({'D.x': at, 'bin': bin_now}, commit=False).success
    way = 10.0 - here.points['D'][0]
    fresh.adopt(here)
    assert not fresh.solve({'D.x': at + 1e-4 * way, 'bin': bin_now}, commit=False).success


def test_an_angle_out_of_reach_is_named_beside_the_point_that_does_not_move():
    """The loader's bin hinge kept at its x and the bin turned to 9 rad: the bin angle is what
    is out of reach. The refusal had said "D.x = 2.2 m is out of reach ... reachable up to
    D.x = 2.2 m, 7.99e-15 m short", naming only the coordinate that does not move."""
    engine = Engine(load('front_loader'), EngineSettings())
    x = engine.last.points['D'][0]
    r = engine.target({'D.x': x, 'bin': 9.0})
    assert not r.success
    assert r.reason.startswith(f'D.x = {x:.6g} m with bin as given is out of reach'), r.reason
    assert 'every known moved together, it is reachable ' in r.reason


def test_a_target_a_restart_places_is_answered():
    """From this loader state the target's first walk stalls (in a local least-squares
    minimum), and a restart from another configuration of the mode places it: it had been
    refused as out of reach while the restarts were skipped for such refusals. Oracle: the
    forward solve that made the target (Z1 1.7401, Z2 2.0105, inside the limits the loader
    keeps its mode in)."""
    engine = Engine(load('front_loader'), EngineSettings())
    made = engine.command({'Z1': 1.7401330279289802, 'Z2': 2.010454394967944})
    target = {'D.x': made.points['D'][0], 'bin': made.links['bin']}
    assert engine.command({'Z1': 1.5042122436524599, 'Z2': 1.9816756301105216}).success
    r = engine.target(target)
    assert r.success, r.reason
    for a in ('Z1', 'Z2'):
        assert r.inputs[a] == pytest.approx(made.inputs[a], abs=1e-9)


def test_a_target_of_two_points_out_of_reach_is_refused_not_raised():
    """Two two-link arms (4 degrees of freedom), P1 sent beyond its arm's reach beside a
    reachable P2: the refusal measured how far each other known moves by its size taken as a
    number, and a point's raised TypeError inside Engine.target (a review of this change).
    Oracle: the arm's reach, |O1 P1| <= 0.3 + 0.2 m < 3 m."""
    from linkage_ros.core.model import Scene

    pts, links, acts = {}, {}, {}
    for s, x in ((1, 0.0), (2, 2.0)):
        pts |= {f'O{s}': [x, 0.0], f'A{s}': [x, 0.3], f'P{s}': [x + 0.2, 0.3]}
        links |= {f'upper{s}': [f'O{s}', f'A{s}'], f'fore{s}': [f'A{s}', f'P{s}']}
        acts |= {
            f'shoulder{s}': {'type': 'angle', 'link': f'upper{s}', 'pivot': f'O{s}'},
            f'elbow{s}': {
                'type': 'angle',
                'link': f'fore{s}',
                'pivot': f'A{s}',
                'relative_to': f'upper{s}',
            },
        }
    data = {'points': pts, 'links': {'ground': ['O1', 'O2'], **links}, 'actuators': acts}
    engine = Engine(Scene.from_dict(data).mechanism, EngineSettings())
    r = engine.target({'P1.x': 3.0, 'P1.y': 0.0, 'P2.x': 2.3, 'P2.y': 0.1})
    assert not r.success
    assert r.reason.startswith('point P1 = (3, 0) m with point:P2 as given is out of reach')


#: a Stephenson III press (an outside reviewer's): a crank-rocker whose coupler point C drives a
#: ram D on a vertical guide through a rod; Newton places the ram for a ram target
PRESS = {
    'name': 'stephenson_press',
    'points': {
        'O2': [0, 0],
        'O4': [0.35, 0.05],
        'A': [0.05, 0.08660254037844],
        'B': [0.2726040368306, 0.2877180365161],
        'C': [0.07062501819834, 0.2351778028696],
        'D': [0.12, -0.2121052296412],
    },
    'links': {
        'ground': ['O2', 'O4'],
        'crank': ['O2', 'A'],
        'coupler': ['A', 'B', 'C'],
        'rocker': ['O4', 'B'],
        'rod': ['C', 'D'],
        'ram': ['D'],
    },
    'sliders': [
        {
            'name': 'ram_slide',
            'guide': 'ground',
            'slider': 'ram',
            'point': 'D',
            'direction': [0, -1],
            'origin': [0.12, 0.0],
        }
    ],
    'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
}


def test_a_slide_target_only_another_mode_reaches_says_the_others_are_searched_on_request():
    """The ram 0.4 m down is beyond its stroke in the drawn mode and within it in another: the
    refusal says that other modes are searched on request (it said so for point targets only),
    and the request that allows the change answers it: D at (0.12, -0.4), every link its drawn
    length. A target no mode reaches, asked that way, does not say it again."""
    import math

    from linkage_ros.core.model import Scene

    e = Engine(Scene.from_dict(PRESS).mechanism, EngineSettings())
    r = e.target({'ram_slide': 0.4})
    assert not r.success
    assert r.reason.endswith(
        'other assembly modes are searched on request (~/target_any_mode, linkage solve --any-mode)'
    )
    r = e.target({'ram_slide': 0.4}, allow_mode_change=True)
    assert r.success and r.mode_change, r.reason
    p = PRESS['points']
    assert math.dist(r.points['D'], (0.12, -0.4)) < 1e-12
    for link, names in PRESS['links'].items():
        for a, b in zip(names, names[1:]):
            drawn = math.dist(p[a], p[b])
            assert abs(math.dist(r.points[a], r.points[b]) - drawn) < 1e-12, (link, a, b)
    far = e.target({'ram_slide': 0.6}, allow_mode_change=True)
    assert not far.success and 'searched on request' not in far.reason


#: a Klann-type leg (an outside reviewer's): the foot G's x, driven by the crank from the
#: drawing toward larger x, turns back at -0.797 m; it reaches -0.559 m elsewhere on the turn
KLANN = {
    'name': 'klann_leg',
    'points': {
        'O': [0, 0],
        'P1': [-0.3, 0.16],
        'P2': [-0.22, -0.1],
        'A': [0.06, 0.1039230484541],
        'B': [-0.2399596285537, 0.0990015407679],
        'E': [-0.4408457837512, 0.1886940858872],
        'F': [-0.2890028333463, 0.3997479141215],
        'G': [-0.7988942981002, -0.1603062885717],
    },
    'links': {
        'ground': ['O', 'P1', 'P2'],
        'crank': ['O', 'A'],
        'arm': ['A', 'B', 'E'],
        'lower_rocker': ['P2', 'B'],
        'leg': ['E', 'F', 'G'],
        'upper_rocker': ['P1', 'F'],
    },
    'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O'}},
}


def test_a_coordinate_refusal_says_its_edge_is_the_ways_not_the_points_reach():
    """The foot beyond its reach (G.x = -0.5) is refused with the edge of the straight way from
    the drawing; that edge is where the way folds, not how far the foot reaches: a target past
    it (-0.6) is answered, and the range the refusal points to reaches past it too."""
    from linkage_ros.core import motion
    from linkage_ros.core.model import Scene

    mech = Scene.from_dict(KLANN).mechanism
    r = Engine(mech, EngineSettings()).target({'G.x': -0.5})
    assert not r.success
    edge = float(re.search(r'up to G\.x = (\S+) m', r.reason).group(1))
    assert "(that way's edge; the point's whole reach: linkage range --point G)" in r.reason
    beyond = Engine(mech, EngineSettings()).target({'G.x': -0.6})
    assert edge < -0.6 and beyond.success, beyond.reason
    assert abs(beyond.points['G'][0] + 0.6) < 1e-12
    reach = motion.reachable_region(mech, 'G')['extent'][0][1]
    assert -0.6 < reach < -0.5


def test_a_joint_or_slide_target_out_of_reach_is_told_its_edge():
    """A rocker angle or a slider position beyond what the mechanism reaches was refused in the
    solver's terms only ('RRR dyad ... does not close; misses by 0.044 m'), where a command
    gets the reachable range and a point target its edge (a new user's find). Now the edge on
    the way there: the crank-rocker's rocker stops at its extreme, where crank and coupler
    lie in line, folded (|O2 B| = coupler - crank: the cosine rule), and the slider-crank's
    slider at its stroke's ends (|O2 B| = rod -+ crank, on the line of the slide)."""
    from linkage_ros.core.solver.reach import reach_edge

    # the four-bar: ground 0.3, crank 0.1, coupler 0.25, rocker 0.2 (O2 at 0, O4 at (0.3, 0))
    d = 0.25 - 0.1  # B at its least distance from O2: the rocker's largest angle
    cos_o4 = (0.3**2 + 0.2**2 - d**2) / (2 * 0.3 * 0.2)  # the angle O2-O4-B
    rocker_max = math.pi - math.acos(cos_o4)  # (B above the ground line, as drawn)
    e = Engine(load('four_bar'), EngineSettings())
    r = e.target({'rocker': 3.0})
    assert not r.success
    assert r.reason.startswith(
        'rocker = 3 rad is out of reach: on the way there from the current configuration it '
        f'is reachable up to rocker = {rocker_max:.6g} rad'
    ), r.reason
    assert "(that way's edge); cannot assemble" in r.reason  # (no range check does not print)
    edge = reach_edge(e.solver_for(['rocker']), {'rocker': 3.0}, e.last)
    assert edge is not None and edge.unit == 'rad'
    assert abs(edge.edge[0] - rocker_max) < 1e-9
    assert abs(edge.short_m - (3.0 - rocker_max)) < 1e-9
    # the slider-crank: its stroke's near end, found the same way
    sc = Engine(load('slider_crank'), EngineSettings())
    r = sc.target({'slider': 0.01})
    got = float(re.search(r'up to slider = (\S+) m', r.reason).group(1))
    # crank 0.05, rod 0.18, the line of the slide 0.01 above O2 (config/slider_crank.yaml);
    # the slide measured from O2's foot on that line
    near = math.sqrt((0.18 - 0.05) ** 2 - 0.01**2)
    assert abs(got - near) < 1e-5, (got, near)  # (the refusal's 6 digits)


def test_a_point_target_out_of_reach_names_the_knowns_it_keeps():
    """~/target_point/L with target_point_hold [bucket]: the refusal said 'point L = (9, -0.25)
    m is out of reach' without the bucket held (a new user's find), where ~/target's
    [L.x, L.y, bucket] says 'with bucket as given' when the bucket moves on the way. A known
    the way keeps is named too; the edge is where the march stops either way (the same)."""
    e = Engine(load('excavator'), EngineSettings(target_point_hold=('bucket',)))
    held = e.target_point('L', (9.0, -0.25))
    assert not held.success
    assert held.reason.startswith(
        'point L = (9, -0.25) m with bucket as it is now is out of reach: on the straight way'
    ), held.reason
    same = e.target({'L.x': 9.0, 'L.y': -0.25, 'bucket': e.last.links['bucket']})
    assert same.reason == held.reason


def test_a_joint_targets_edge_stays_in_the_mode_the_target_rule_answers():
    """The non-Grashof inverted slider-crank with crank limits 0.01 rad inside its toggles: the
    march toward rocker = -1.3 passed the toggle into the other sign and quoted 4.91375 rad,
    which the same request then refused as another mode (an adversary's find). The way stops
    where it would leave the mode: at the crank's limit, 5.8704 rad, where the forward
    solve (another path than the inverse march) puts the rocker."""
    from linkage_ros.core.solver import Solver

    mech = load('inverted_slider_crank_oscillating')
    at_limit = Solver(mech).solve({'crank': 5.8704})
    assert at_limit.success and at_limit.branch == '+'
    want = at_limit.links['rocker'] % (2 * math.pi)
    e = Engine(mech, EngineSettings())
    r = e.target({'rocker': -1.3})
    got = float(re.search(r'up to rocker = (\S+) rad', r.reason).group(1))
    assert abs(got - want) < 1e-5, (got, want, r.reason)  # (the refusal's 6 digits)
    assert e.target({'rocker': got - 1e-3}).success


def test_crank_limits_short_of_the_toggles_do_not_make_the_other_sign_another_circuit():
    """Its other sign lies beyond a toggle the limits keep the crank from (the scene's own
    comment: one circuit through both signs); the refusal called it another circuit that only
    taking the mechanism apart reaches (an adversary's find). The crank-rocker's still is."""
    e = Engine(load('inverted_slider_crank_oscillating'), EngineSettings())
    r = e.target({'rocker': 4.0})
    assert not r.success and 'another circuit' not in r.reason, r.reason
    assert 'only a motion through a toggle position, or taking the mechanism apart' in r.reason
    r = Engine(load('four_bar'), EngineSettings()).target({'B': -1.2})
    assert 'reachable only in another circuit' in r.reason
