"""Smoke test of the benchmark machinery (linkage_ros.bench) on tiny sizes.

Never asserts a timing: only that every measurement runs, the report has its structure, the
50-digit reference is right (checked against geometry written here) and ``--write`` keeps the
hand-written introduction above the marker line.
"""

import json
import math
import time
from dataclasses import replace

import numpy as np
import pytest

from linkage_ros import bench
from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.model import Scene
from linkage_ros.resources import scene_path

INTRO = '# Benchmarks\n\nHand-written introduction that the tool must keep.\n'


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    """`linkage bench --quick --no-node --write ... --json ...` once for the whole module."""
    d = tmp_path_factory.mktemp('bench')
    md = d / 'BENCHMARKS.md'
    md.write_text(f'{INTRO}\n{bench.MARKER}\nold generated text\n')
    js = d / 'raw.json'
    code = cli_main(['bench', '--quick', '--no-node', '--write', str(md), '--json', str(js)])
    return code, md, d / 'bench_tradeoff.png', json.loads(js.read_text())


def test_cli_writes_report_below_the_marker(quick_run):
    code, md, png, _ = quick_run
    assert code == 0
    text = md.read_text()
    assert text.startswith(INTRO)
    assert text.count(bench.MARKER) == 1
    assert 'old generated text' not in text
    for heading in (
        '## Run',
        '## Targets',
        '## Speed against accuracy',
        '## Newton vs scipy.optimize.root',
        '## Vectorised four-bar throughput',
        '## Cost against what the scene asks',
        '## Node latency',
        '## Interpretation',
    ):
        assert heading in text
    assert '(bench_tradeoff.png)' in text
    assert png.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    # a second write replaces the generated part again and still keeps the introduction
    bench.write_report(md, 'new body\n')
    text = md.read_text()
    assert text.startswith(INTRO) and text.rstrip().endswith('new body')
    # a file without the marker is all introduction: kept, marker and report appended
    bare = md.parent / 'bare.md'
    bare.write_text(INTRO)
    bench.write_report(bare, 'body\n')
    assert bare.read_text() == f'{INTRO}\n{bench.MARKER}\n\nbody\n'


def test_render_from_json(quick_run, tmp_path):
    """--render re-renders an earlier run's JSON dump without measuring again."""
    _, md, _, rep = quick_run
    js = tmp_path / 'raw.json'
    js.write_text(json.dumps(rep))
    out = tmp_path / 'again.md'
    assert cli_main(['bench', '--render', str(js), '--write', str(out)]) == 0
    text = out.read_text()
    assert bench.MARKER in text and '## Targets' in text
    assert (tmp_path / 'bench_tradeoff.png').exists()
    assert rep['command'] == f'linkage bench --quick --write {md} --no-node'


def test_report_structure(quick_run):
    _, _, _, rep = quick_run
    assert set(rep['scenes']) == set(bench.SCENES)
    for key in ('nproc', 'cpu', 'python', 'numpy'):
        assert rep['machine'][key]
    fams = {}
    for r in rep['settings']:
        fams.setdefault(r['scene'], set()).add((r['family'], r['tol']))
        assert r['scalar_us'] is not None and r['scalar_us'] > 0
        assert r['failures'] == 0, r
    for scene in bench.SCENES:
        want = (
            {('dyad', None), ('kernel', 1e-12)}
            | {('newton', t) for t in bench.NEWTON_TOLS}
            | {('scipy', t) for t in bench.SCIPY_XTOLS}
        )
        if scene in ('four_bar', 'slider_crank'):
            want.add(('direct', None))
        assert fams[scene] == want
    # accuracy (not speed): closed forms are exact to rounding, Newton meets its tolerance
    for r in rep['settings']:
        if r['family'] in ('direct', 'dyad'):
            assert r['err_max'] < 1e-13 and r['batch_us'] > 0 and r['batch_err_max'] < 1e-13
        if r['family'] == 'newton':
            assert r['err_max'] < 100 * r['tol']
    t = rep['throughput'][0]
    assert set(t['rate']) == {'numpy baseline', 'fourbar_forward', 'Solver.solve_batch'}
    assert t['all_ok'] and max(t['max_angle_diff_vs_baseline'].values()) < 1e-12
    assert [o['outputs'] for o in rep['outputs']] == [['Z1_rod'], ['A'], ['L'], None]
    assert rep['outputs'][0]['plan_steps'] < rep['outputs'][-1]['plan_steps']
    assert rep['node'] == {'skipped': '--no-node given'}
    names = [t['target'] for t in rep['targets']]
    assert any('numpy baseline' in n for n in names)
    # per scene: the scalar Newton solve and the vectorised batch of instances, each vs scipy
    same_residual = [n for n in names if 'scipy' in n and 'textbook' not in n]
    assert sum('vectorised' not in n for n in same_residual) == len(bench.SCENES)
    assert sum('vectorised' in n for n in same_residual) == len(bench.SCENES)
    # the solver core against its hand-written baselines: five targets, each with its numbers
    core = [t for t in rep['targets'] if 'four-bar' in t['target'] or 'textbook' in t['target']]
    assert len([t for t in core if 'hand-written' in t['target'] or 'textbook' in t['target']]) == 2
    assert rep['core_speed']['scalar']['max_point_diff_m'] < 1e-12
    newton = [r for r in rep['settings'] if r['family'] == 'newton']
    assert newton and all(r['batch_us'] > 0 and r['batch_failures'] == 0 for r in newton)
    assert all(r['batch_err_max'] <= 100 * max(r['tol'], 1e-13) for r in newton)
    # the batched 1e-12 solve is timed paired with scipy sweeps (the same moment), the rest not
    assert all((r['batch_vs_scipy'] or 0) > 0 for r in newton if r['tol'] == 1e-12)
    assert all(r['batch_vs_scipy'] is None for r in newton if r['tol'] != 1e-12)
    assert all(t['met'] in (True, False, None) for t in rep['targets'])
    # the fleet case: the three runs of the real command give the same bytes, Parquet is smaller
    fleet = rep['fleet']
    assert set(fleet['runs']) == {'serial', 'jobs2', 'cluster2'}
    assert all(r['exit'] == 0 and r['identical_to_serial'] for r in fleet['runs'].values())
    table = fleet['parquet_vs_csv']
    assert table['rows'] == bench.QUICK.parquet_rows
    assert 0 < table['parquet']['bytes'] < table['csv']['bytes']
    assert sum('faster than one after the other' in n for n in names) == 2
    # big scenes: each quick size timed (range and check), its targets stated
    assert [r['actuators'] for r in rep['scaling']] == list(bench.QUICK.scaling)
    assert all(r['range_s'] > 0 and r['check_s'] > 0 and r['repeats'] >= 1 for r in rep['scaling'])
    assert sum('independent four-bars' in n for n in names) == 2
    assert sum('300 actuators' in n for n in names) == 2


def test_the_big_scene_is_n_closed_four_bars():
    """The scaling case's scene: every four-bar drawn with config/four_bar.yaml's lengths."""
    from linkage_ros.bench.scaling import LENGTHS, four_bars_scene

    scene = four_bars_scene(7)
    pts = {k: complex(*v) for k, v in scene['points'].items()}
    for k in range(7):
        o2, o4, a, b = (pts[f'{p}_{k}'] for p in ('O2', 'O4', 'A', 'B'))
        got = (abs(o4 - o2), abs(a - o2), abs(b - a), abs(b - o4))
        assert np.allclose(got, LENGTHS, rtol=0, atol=1e-15)
    mech = Scene.from_dict(scene).mechanism
    assert len(mech.actuators) == 7 and mech.dof == 7


def _textbook_fourbar(l1, l2, l3, l4, theta, branch):
    """Points of the four-bar from the cosine rule, written here (not the core's formula)."""
    a = complex(l2 * math.cos(theta), l2 * math.sin(theta))
    o4 = complex(l1, 0.0)
    d = abs(o4 - a)
    gamma = math.acos((l3 * l3 + d * d - l4 * l4) / (2 * l3 * d))
    u = (o4 - a) / d
    b = a + l3 * u * complex(math.cos(gamma), branch * math.sin(gamma))
    return a, b


def test_reference_is_independent_and_exact():
    mech = bench.load_scene('four_bar')
    sc = mech.shortcut
    ref = bench.MpReference(mech)
    assert ref.n == 6  # A, B, P unknown; O2, O4 on the ground
    for theta in (0.3, 1.0471975511965976, 2.5, -2.0):
        a, b = _textbook_fourbar(
            sc['ground'], sc['crank'], sc['coupler'], sc['rocker'], theta, sc['branch']
        )
        # start far (1e-3 of the length scale) from the answer: the reference must still land
        # on it, i.e. it does not just echo its start
        start = {p: tuple(np.asarray(v) + 3e-4) for p, v in mech.points.items()}
        start['A'] = (a.real + 3e-4, a.imag - 2e-4)
        start['B'] = (b.real - 3e-4, b.imag + 1e-4)
        pts, res = ref.solve({'crank': theta}, start)
        assert res < 1e-40
        for p, z in (('A', a), ('B', b)):
            xh, xl, yh, yl = pts[p]
            assert abs(xh - z.real) < 1e-15 and abs(yh - z.imag) < 1e-15
        # coupler point P keeps its reference distances to A and B
        for q in ('A', 'B'):
            d_now = math.hypot(pts['P'][0] - pts[q][0], pts['P'][2] - pts[q][2])
            d_ref = float(np.hypot(*(mech.points['P'] - mech.points[q])))
            assert abs(d_now - d_ref) < 1e-15


def test_reference_covers_every_benchmark_scene():
    for name in bench.SCENES:
        mech = bench.load_scene(name)
        ref = bench.MpReference(mech)
        cmd = bench.sweep_inputs(mech, 4)[1]
        from linkage_ros.core.solver import Solver

        r = Solver(mech, method='closed_form').solve(cmd)
        assert r.success
        hi, lo, worst = bench.reference_points(ref, [cmd], [r.points])
        assert worst < 1e-40
        pts = np.array([[r.points[p] for p in mech.points]])
        assert bench.point_errors(pts, hi, lo, mech.length_scale)[0] < 1e-14
        # a point 1e-6 off shows as an error of 1e-6 / length scale
        pts[0, 0, 0] += 1e-6
        err = bench.point_errors(pts, hi, lo, mech.length_scale)[0]
        assert err == pytest.approx(1e-6 / mech.length_scale, rel=1e-6)


def test_numpy_baseline_matches_textbook():
    theta = np.array([0.3, 1.0, 2.5, -2.0])
    t3, t4 = bench.numpy_circle_baseline(0.3, 0.1, 0.25, 0.2, theta, 1.0)
    for th, a3, a4 in zip(theta, t3, t4):
        a, b = _textbook_fourbar(0.3, 0.1, 0.25, 0.2, th, 1)
        assert math.isclose(math.atan2((b - a).imag, (b - a).real), a3, abs_tol=1e-12)
        assert math.isclose(math.atan2(b.imag, b.real - 0.3), a4, abs_tol=1e-12)


def test_sustained_rate():
    runs = [
        {'rate': 200.0, 'lost': 0, 'achieved_rate': 200.0},
        {'rate': 500.0, 'lost': 0, 'achieved_rate': 499.0},
        {'rate': 1000.0, 'lost': 3, 'achieved_rate': 1000.0},
        {'rate': 2000.0, 'lost': 0, 'achieved_rate': 1500.0},
    ]  # the driver could not keep up
    assert bench.sustained_rate(runs) == 500.0
    assert bench.sustained_rate(runs[2:]) is None


def test_node_benchmark_machinery():
    """The relay and the node under the driver, tiny sizes: structure only."""
    pytest.importorskip('rclpy')
    pytest.importorskip('sensor_msgs.msg')
    sizes = replace(
        bench.QUICK,
        node_rates=(100.0,),
        node_seconds=0.3,
        node_warmup=3,
        node_ping=5,
        node_deep_depth=37,
        node_deep_rates=(50.0,),
        node_all_rate=100.0,
    )
    rep = bench.bench_node(sizes)
    assert 'skipped' not in rep, rep
    for label in ('relay', 'node'):
        res = rep['targets'][label]
        assert res['ok'], res
        assert res['depth'] == bench.DEFAULT_DEPTH
        assert res['latency']['n'] + res['latency']['timeouts'] == 5
        (run,) = res['runs']
        assert run['rate'] == 100.0 and run['sent'] == 30
        assert run['received'] + run['lost'] == run['sent']
        # the same program with the deeper queue (the node accepted -p queue_depth:=37), at
        # the deep rates only and without the latency phase
        deep = rep['targets'][f'{label}_deep']
        assert deep['ok'], deep
        assert deep['depth'] == 37 and 'latency' not in deep
        (run,) = deep['runs']
        assert run['rate'] == 50.0 and run['sent'] == 15
        assert run['received'] + run['lost'] == run['sent']
    # every output subscribed, per scene: the node answered with every output, the relay too
    assert rep['all_outputs_rate'] == 100.0
    for scene in ('four_bar', 'excavator'):
        res = rep['all_outputs'][scene]
        for label in ('relay', 'node'):
            assert res[label]['ok'], res[label]
            assert res[label]['sent'] == 30
            assert res[label]['received'] + res[label]['lost'] == 30
        counts = res['node']['outputs']
        # the listener process got one status per command and every point of every answer
        statuses = sum(v for k, v in counts.items() if k.endswith('/status'))
        assert statuses == 30, counts
        n_points = len(Scene.from_yaml(scene_path(scene)).mechanism.outputs)
        assert sum(v for k, v in counts.items() if '/points/' in k) == 30 * n_points, counts
        # the same node again beside a plain rclpy listener (SingleThreadedExecutor)
        plain = res[bench.PLAIN_LISTENER_LABEL]
        assert plain['ok'], plain
        assert (plain['listener'], res['node']['listener']) == ('single', 'events')
        assert plain['received'] + plain['lost'] == 30
        assert sum(v for k, v in plain['outputs'].items() if k.endswith('/status')) == 30
        # the node's CPU per answered command: its whole process over the run
        for label in ('relay', 'node', bench.PLAIN_LISTENER_LABEL):
            run = res[label]
            assert run['target_process_cpu_ms'] is not None and run['target_process_cpu_ms'] >= 0
            assert run['target_cpu_per_answer_us'] == pytest.approx(
                run['target_process_cpu_ms'] * 1e3 / run['received']
            )
    targets = {t['target']: t for t in bench.evaluate_targets({**_minimal_report(), 'node': rep})}
    for scene in ('four_bar', 'excavator'):
        (answered,) = [
            t for k, t in targets.items() if k.startswith(f'{scene}, every output on (points')
        ]
        assert answered['met'] is not None and 'statuses received' in answered['measured']
        assert any(k.startswith(f'{scene}, every output on: node p50 within') for k in targets)
        assert any(
            k.startswith(f'{scene}, every output on, a plain rclpy listener') for k in targets
        )
        (cpu,) = [
            t for k, t in targets.items() if k.startswith(f'{scene}, every output on: node CPU')
        ]
        base = bench.NODE_CPU_BASELINE_US[scene]
        ratio = rep['all_outputs'][scene]['node']['target_cpu_per_answer_us'] / base
        assert cpu['value'] == pytest.approx(ratio) and cpu['met'] == (ratio <= 0.5)
    md = bench.render_markdown({**_minimal_report(), 'node': rep}, 'linkage bench', None)
    assert '**Every output on** (100 Hz' in md
    assert '| four_bar | node | 30 |' in md and '| excavator | relay | 30 |' in md
    assert f'| excavator | {bench.PLAIN_LISTENER_LABEL} | 30 |' in md
    assert 'CPU per answer (us)' in md
    assert '| relay | 10 |' in md and '| node | 10 |' in md
    assert '| relay_deep | 37 | 50 |' in md and '| node_deep | 37 | 50 |' in md
    assert 'keep last 37' in md


def test_node_targets_and_interpretation_with_both_queue_depths():
    """Synthetic node results (no ROS): the 1 kHz target is read at the default depth and,
    as its own row, at the deeper one; the interpretation reports the losses at both."""

    def run(rate, lost):
        return {
            'rate': rate,
            'sent': int(3 * rate),
            'received': int(3 * rate) - lost,
            'lost': lost,
            'achieved_rate': rate,
            'p50_ms': 1.0,
            'p99_ms': 2.0,
            'max_ms': 3.0,
        }

    lat = {'n': 10, 'timeouts': 0, 'p50_ms': 1.5, 'p99_ms': 3.0, 'max_ms': 4.0}
    targets = {
        'relay': {
            'ok': True,
            'depth': 10,
            'latency': dict(lat, p50_ms=1.3),
            'runs': [run(500.0, 0), run(1000.0, 4)],
        },
        'node': {'ok': True, 'depth': 10, 'latency': lat, 'runs': [run(500.0, 0), run(1000.0, 17)]},
        'relay_deep': {'ok': True, 'depth': 100, 'runs': [run(1000.0, 0)]},
        'node_deep': {'ok': True, 'depth': 100, 'runs': [run(1000.0, 0)]},
    }
    for t in targets.values():
        t['sustained_rate'] = bench.sustained_rate(t['runs'])
    node = {
        'domain_id': 7,
        'depth': 10,
        'deep_depth': 100,
        'deep_rates': [1000.0],
        'seconds_per_rate': 3.0,
        'ping_pong_n': 10,
        'targets': targets,
    }
    rows = {r['target']: r for r in bench.evaluate_targets({'node': node, 'scenes': {}})}
    plain = rows['node sustains 1000 Hz with zero loss']
    assert plain['met'] is False and plain['measured'].startswith('17 lost of 3000')
    (deep,) = [r for k, r in rows.items() if 'queue_depth 100' in k]
    assert deep['met'] is True and '0 lost of 3000' in deep['measured']
    assert 'relay 0 lost of 3000' in deep['measured']
    text = bench.interpretation(
        {'node': node, 'settings': [], 'scenes': {}, 'throughput': [], 'outputs': []}
    )
    assert 'queue depth 10 -> 100: node 1000 Hz 17 -> 0; relay 1000 Hz 4 -> 0' in text


def _minimal_report():
    return {
        'machine': bench.machine_info(),
        'sizes': bench.QUICK.__dict__,
        'date': 'now',
        'seconds': 1.0,
        'targets': [],
        'settings': [],
        'scenes': {},
        'throughput': [],
        'outputs': [],
    }


def test_process_cpu_is_the_kernels_count_of_the_whole_process():
    """process_cpu_s against os.times() of this very process (user + system, every thread)."""
    import os
    import threading

    def spin():
        t_end = time.process_time() + 0.2
        while time.process_time() < t_end:
            pass

    worker = threading.Thread(target=spin)  # CPU in another thread counts too
    worker.start()
    worker.join()
    before = os.times()
    got = bench.process_cpu_s(os.getpid())
    after = os.times()
    assert got is not None
    assert before.user + before.system - 0.02 <= got <= after.user + after.system + 0.02
    assert bench.process_cpu_s(2**22 + 12345) is None  # no such process


def test_answer_gaps_name_the_longest_silence_and_the_sends_around_it():
    """The largest gap between answers (ms), when it began (s after the first send) and the
    largest gap between sends around it, worked out by hand for a run with one stall."""
    from linkage_ros.bench.ros_driver import answer_gaps

    ms = 1_000_000
    sent = [k * 2 * ms for k in range(10)]  # every 2 ms
    answered = [s + ms for s in sent[:4]] + [s + ms + 50 * ms for s in sent[4:]]
    gaps = answer_gaps(sent, answered)
    assert gaps['max_gap_ms'] == pytest.approx(52.0)  # 7 ms -> 59 ms
    assert gaps['max_gap_at_s'] == pytest.approx(0.007)
    assert gaps['send_gap_ms'] == pytest.approx(2.0)  # the driver went on sending: the target
    assert answer_gaps(sent, answered[:1])['max_gap_ms'] is None


def test_flood_targets_compare_each_flood_with_its_reference():
    """The 2 MB flood against the small new-name flood, the trajectory flood against the run
    without one: within 2x in lost commands and p99, both."""
    from linkage_ros.bench.collect import flood_targets

    def run(kind, lost, p99):
        return {
            'flood_kind': kind,
            'rate': 500.0,
            'flood_rate': 10.0,
            'flood_sent': 30,
            'sent': 1500,
            'lost': lost,
            'p99_ms': p99,
            'achieved_rate': 500.0,
            'max_gap_ms': 12.0,
        }

    floods = [run('none', 4, 2.0), run('new_sets', 1, 1.5), run('huge', 2, 3.0)]
    met = [t['met'] for t in flood_targets(floods)]
    assert met == [False, True]  # the small flood must lose none; the 2 MB one within 2x of it
    floods += [run('trajectory', 9, 3.0)]
    (traj,) = [t for t in flood_targets(floods) if 'trajectory' in t['target']]
    assert traj['met'] is False and 'largest gap between answers 12 ms' in traj['measured']
    floods[-1] = run('trajectory', 8, 4.0)
    (traj,) = [t for t in flood_targets(floods) if 'trajectory' in t['target']]
    assert traj['met'] is True
    assert 'plan worker' not in traj['measured']  # a run that did not record it says nothing
    floods[-1] = {**run('trajectory', 8, 4.0), 'target_children_cpu_ms': 1234.4}
    (traj,) = [t for t in flood_targets(floods) if 'trajectory' in t['target']]
    assert 'the plan worker used 1234 ms of CPU' in traj['measured']


def test_children_cpu_counts_the_cpu_of_a_child_process():
    """The plan worker's CPU in a flood run: the CPU of the target's child processes, here a
    child that burns a known amount (its own process_time, printed) and then waits."""
    import os
    import subprocess
    import sys

    from linkage_ros.bench.ros_driver import children_cpu_s

    burn = (
        'import sys, time\n'
        't = time.process_time()\n'
        'while time.process_time() - t < 0.3: pass\n'
        'print(time.process_time(), flush=True)\n'
        'sys.stdin.read()\n'
    )
    child = subprocess.Popen(
        [sys.executable, '-c', burn], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        used = float(child.stdout.readline())
        got = children_cpu_s(os.getpid())
        # /proc counts in clock ticks (10 ms); other children of this process can only add
        assert got is not None and got >= used - 0.02
    finally:
        child.communicate('')
    assert children_cpu_s(2**22 + 12345) is None  # no such process


def test_bench_cases_select_measurements_and_refuse_unknown_ones(capsys):
    from linkage_ros.cli.parser import main

    assert main(['bench', '--cases', 'node_floods,nonsense']) == 2
    assert "unknown case(s) ['nonsense']" in capsys.readouterr().err
    assert main(['bench', '--cases', 'throughput', '--write', 'x.md']) == 2
    assert '--write takes a whole run' in capsys.readouterr().err


def test_batched_newton_ratio_reads_the_pairs_and_falls_back_for_old_dumps():
    """The batched-Newton target divides by the paired scipy timing when the run has it; a
    dump from before (no batch_vs_scipy) gives the two-phase ratio, saying so."""
    from linkage_ros.bench.collect import batch_vs_scipy

    sp = {'scalar_us': 400.0}
    assert batch_vs_scipy({'batch_us': 20.0, 'batch_vs_scipy': 17.5}, sp)[0] == 17.5
    ratio, against = batch_vs_scipy({'batch_us': 20.0}, sp)
    assert ratio == 20.0 and against == '400 us'


@pytest.mark.parametrize(
    ('argv', 'said'),
    [
        (['--json', '{tmp}/no/x.json'], '--json {tmp}/no/x.json: folder {tmp}/no does not exist'),
        (['--plot', '{tmp}/no/p.png'], '--plot {tmp}/no/p.png: folder {tmp}/no does not exist'),
        (['--render', '{tmp}/none.json'], '--render {tmp}/none.json: cannot be read'),
        (['--render', '{tmp}/bad.txt'], '--render {tmp}/bad.txt: not JSON'),
        (['--render', '{tmp}/empty.json'], 'not a linkage bench --json dump (it lacks machine'),
        (['--render', '{tmp}/part.json'], 'not a whole linkage bench --json dump (KeyError'),
    ],
)
def test_bench_outputs_and_dumps_are_refused_before_any_work(capsys, tmp_path, argv, said):
    """A --json or --plot to a folder that does not exist lost a whole run at its end (a
    traceback) or was made, and a --render of a missing, non-JSON or foreign file was a
    traceback (a new user): refused first, in one line, exit 2, nothing written."""
    (tmp_path / 'bad.txt').write_text('x')
    (tmp_path / 'empty.json').write_text('{}')
    (tmp_path / 'part.json').write_text(
        '{"machine": {}, "targets": {}, "settings": {}, "seconds": 1}'
    )
    argv = [a.format(tmp=tmp_path) for a in argv]
    rc = cli_main(['bench', '--quick', '--no-node', '--no-fleet', '--cases', 'tradeoff', *argv])
    err = capsys.readouterr().err
    assert rc == 2 and said.format(tmp=tmp_path) in err, err
    assert not (tmp_path / 'no').exists()
    assert 'Traceback' not in err and err.count('\n') == 1
