"""The node's sections of the bench report: latency, sustained rate, every output on, and their
lines of the interpretation (prose, not library code)."""

from __future__ import annotations

from .all_outputs import PLAIN_LISTENER_LABEL
from .collect import rate_text
from .settings import DEFAULT_DEPTH


def node_markdown(node: dict) -> str:
    """The node section: latency, sustained rate and every output on (ros_latency.py)."""
    L: list[str] = []
    w = L.append
    w('## Node latency and loss-free rate\n')
    if node.get('skipped'):
        w(f'Skipped: {node["skipped"]}.\n')
    else:
        w(
            'One driver in the benchmark process publishes sensor_msgs/JointState commands '
            '(stamp = send time, the four-bar crank stepping through a full turn) and records the '
            'arrival of each answer by its stamp (latency = arrival - stamp, one clock). Targets, '
            'each a separate process started by the benchmark: `linkage_node` (four_bar scene; '
            'command -> parse and check -> closed-form solve with continuity and a full Result '
            '-> joint_states; points, markers and status are built only while something '
            'subscribes to them, and here nothing does) and the bare rclpy '
            'relay `bench/relay_node.py` (subscribe, publish the same message back). Reliable QoS '
            f"(commands keep last {node.get('depth', DEFAULT_DEPTH)} in both targets, the node's "
            'default `queue_depth`; joint_states keep last 100, its default `output_depth`; '
            '1000 on the driver), '
            f'ROS_DOMAIN_ID {node["domain_id"]}, localhost discovery, discovery and '
            'warm-up awaited before measuring.'
            + (
                f' The rate runs are repeated at {", ".join(f"{r:g}" for r in node["deep_rates"])} '
                f'Hz by a second relay and node with keep last {node["deep_depth"]} (`relay_deep`: '
                f'`--depth {node["deep_depth"]}`, `node_deep`: `-p queue_depth:='
                f'{node["deep_depth"]}`): a deeper queue rides out longer stalls of the target, '
                'it cannot raise the rate it keeps up with.'
                if node.get('deep_rates')
                else ''
            )
            + '\n'
        )
        w(
            f'**Latency** (paired: one command outstanding at a time, relay and node taking turns, '
            f'{node["ping_pong_n"]} commands each, one every 5 ms):\n'
        )
        w('| process | answered | p50 (ms) | p99 (ms) | max (ms) |')
        w('|---|---:|---:|---:|---:|')
        for label, res in node['targets'].items():
            lt = res.get('latency')
            if lt:
                w(
                    f'| {label} | {lt["n"]} | {_fmt_ms(lt["p50_ms"])} | {_fmt_ms(lt["p99_ms"])} | '
                    f'{_fmt_ms(lt["max_ms"])} |'
                )
        w('')
        w(
            f'**Sustained rate** (one target at a time, alternating at each rate, '
            f'{node["seconds_per_rate"]:g} s per rate; '
            'loss = sent - received after a 2 s drain; latency here includes queueing):\n'
        )
        w(
            '| process | queue depth | rate (Hz) | achieved send rate | sent | lost | p50 (ms) | '
            'p99 (ms) | max (ms) | largest gap between answers (ms) | its main thread '
            'waiting for a CPU (ms) |'
        )
        w('|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
        for label, res in node['targets'].items():
            depth = res.get('depth', DEFAULT_DEPTH)
            if not res.get('ok'):
                w(
                    f'| {label} | {depth} | - | - | - | - | - | - | not measured: '
                    f'{res.get("reason")} | | |'
                )
                continue
            for r in res['runs']:
                w(
                    f'| {label} | {depth} | {r["rate"]:g} | {r["achieved_rate"]:.0f} | '
                    f'{r["sent"]} | {r["lost"]} | {_fmt_ms(r["p50_ms"])} | '
                    f'{_fmt_ms(r["p99_ms"])} | {_fmt_ms(r["max_ms"])} | '
                    f'{_fmt_ms(r.get("max_gap_ms"))} | {_fmt_ms(r.get("target_runqueue_ms"))} |'
                )
        w('')
        for label, res in node['targets'].items():
            if res.get('ok'):
                w(
                    f'- {label} (queue depth {res.get("depth", DEFAULT_DEPTH)}): highest loss-free '
                    f'rate {rate_text(res.get("sustained_rate"))} of those tried'
                )
        w('')
        all_out = node.get('all_outputs')
        if all_out:
            _all_outputs_table(w, all_out, node.get('all_outputs_rate'), node['seconds_per_rate'])
    return '\n'.join(L)


def _all_outputs_table(w, all_out: dict, rate, seconds) -> None:
    """Every output subscribed: node vs relay at one rate, per scene."""
    w(
        f'**Every output on** ({rate:g} Hz for {seconds:g} s per target; the driver measures '
        'joint_states as above while a listener in its own process (as RViz or an aggregator '
        'would be) subscribes to every `~/points/<p>`, `~/markers` (transient-local), '
        "`~/status` and `/diagnostics` of the node and counts them (serialized, on rclpy's "
        'EventsExecutor: it stands in for a C++ display, and a Python listener that '
        'deserialised the ~5000 messages/s would take the CPU the node needs on a small '
        'machine); the node at its defaults: '
        'publish_rate 10 Hz, marker_rate 10 Hz, queue depth 10, output depth 100; the relay '
        '(the same depths) answers the same '
        'commands in the same run, just before; latency includes queueing; "most sent in '
        '10 ms" is the driver\'s largest burst, 10 at an even rate: after a stall of its own it '
        'sends what is overdue back to back, which a queue of depth 10 must hold; '
        f'`{PLAIN_LISTENER_LABEL}` is the same node again with a plain rclpy listener '
        '(SingleThreadedExecutor, raw subscriptions) in place of the EventsExecutor one; "CPU '
        'per answer" is the CPU time of the whole target process, every thread, from the first '
        'command to the last answer, divided by the commands answered: a command dropped from a '
        'full queue was still received, and a starved process wakes for fewer commands at a '
        'time, so on a busy machine this grows):\n'
    )
    w(
        '| scene | process | sent | lost | most sent in 10 ms | p50 (ms) | p99 (ms) | largest gap '
        'between answers (ms) | its main thread waiting for a CPU (ms) | CPU per answer (us) '
        '| statuses | points | markers | diagnostics |'
    )
    w('|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
    for scene, res in all_out.items():
        for label in ('relay', 'node', PLAIN_LISTENER_LABEL):
            r = res.get(label)
            if r is None:
                continue
            if not r.get('ok'):
                w(
                    f'| {scene} | {label} | - | - | - | - | - | - | - | - | not measured: '
                    f'{r.get("reason")} | | | |'
                )
                continue
            c = r.get('outputs', {})

            def count(suffix, c=c):
                return sum(v for k, v in c.items() if suffix in k) if c else '-'

            w(
                f'| {scene} | {label} | {r["sent"]} | {r["lost"]} | {r.get("burst_10ms", "-")} | '
                f'{_fmt_ms(r["p50_ms"])} | '
                f'{_fmt_ms(r["p99_ms"])} | {_fmt_ms(r.get("max_gap_ms"))} | '
                f'{_fmt_ms(r.get("target_runqueue_ms"))} | '
                f'{_fmt_cpu(r.get("target_cpu_per_answer_us"))} | {count("/status")} | '
                f'{count("/points/")} | {count("/markers")} | {count("/diagnostics")} |'
            )
    w('')


def _fmt_cpu(v) -> str:
    return '-' if v is None else f'{v:.0f}'


def _fmt_ms(v):
    return '-' if v is None else f'{v:.3f}'


def node_interpretation(node: dict) -> list[str]:
    """The interpretation's lines on the node (none where it was not measured)."""
    lines: list[str] = []
    tg = node.get('targets') or {}
    if tg.get('node', {}).get('ok') and tg.get('relay', {}).get('ok'):
        nl, rl = tg['node'].get('latency') or {}, tg['relay'].get('latency') or {}
        if nl.get('p50_ms') is not None and rl.get('p50_ms') is not None:
            lines.append(
                f'- **Node**: one command costs {nl["p50_ms"]:.2f} ms p50 end to end against '
                f'{rl["p50_ms"]:.2f} ms for a bare relay ({nl["p50_ms"] - rl["p50_ms"]:+.2f} ms); '
                'the node stays loss-free up to '
                f'{rate_text(tg["node"].get("sustained_rate"))} (relay: '
                f"{rate_text(tg['relay'].get('sustained_rate'))}). The difference is the node's "
                'own work per command: parse and check the command, solve it (dyad plan, '
                'continuity, residual, branch and margin) and fill joint_states. Subscribing to '
                '~/points/<p> or ~/status adds their construction to every command; ~/markers '
                'and /diagnostics come from timers and add nothing per command.'
                + _deep_queue_sentence(tg)
            )
    rows = [
        (scene, res['node'], res['relay'])
        for scene, res in (node.get('all_outputs') or {}).items()
        if res.get('node', {}).get('ok')
        and res.get('relay', {}).get('ok')
        and res['node'].get('p50_ms') is not None
        and res['relay'].get('p50_ms') is not None
    ]
    if rows:
        clean = [s for s, n, _ in rows if n['lost'] == 0]
        worst = max(rows, key=lambda t: t[1]['lost'])
        deltas = sorted((n['p50_ms'] - r['p50_ms'], s) for s, n, r in rows)
        lost_text = (
            'lost no command in any'
            if len(clean) == len(rows)
            else f'lost no command in {len(clean)} of them; the most lost: {worst[1]["lost"]} '
            f'of {worst[1]["sent"]} ({worst[0]})'
        )
        relay_lost = sum(r['lost'] for _, _, r in rows)
        lines.append(
            f'- **Every output on** at {node.get("all_outputs_rate", 0):g} Hz, {len(rows)} '
            f'scene(s): the node {lost_text} (relays: {relay_lost} lost in all); its p50 over '
            f'the relay of the same run from {deltas[0][0]:+.2f} ms ({deltas[0][1]}) to '
            f'{deltas[-1][0]:+.2f} ms ({deltas[-1][1]}).'
        )
    return lines


def _deep_queue_sentence(tg: dict) -> str:
    """What the deeper queue changed at the rates measured with both depths (node and relay)."""
    parts = []
    for label in ('node', 'relay'):
        a, b = tg.get(label, {}), tg.get(f'{label}_deep', {})
        if not (a.get('ok') and b.get('ok')):
            continue
        lost = {r['rate']: r['lost'] for r in a['runs']}
        both = [(r['rate'], lost[r['rate']], r['lost']) for r in b['runs'] if r['rate'] in lost]
        if both:
            parts.append(f'{label} ' + ', '.join(f'{hz:g} Hz {l1} -> {l2}' for hz, l1, l2 in both))
    if not parts:
        return ''
    d0 = tg['node'].get('depth', DEFAULT_DEPTH) if 'node' in tg else DEFAULT_DEPTH
    d1 = next(v.get('depth') for k, v in tg.items() if k.endswith('_deep'))
    return (
        f' Lost commands with queue depth {d0} -> {d1}: {"; ".join(parts)}. A deeper queue '
        "(the node's `queue_depth` parameter) absorbs stalls of the target process; above "
        'the rate the target keeps up with (or the driver, one Python process, can send) '
        'nothing but a faster machine helps.'
    )
