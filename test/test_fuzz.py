"""Fuzzing the two doors hostile input comes through: the scene loader (byte strings, YAML
structures, mutations of shipped scenes) and the request checks the node and the bag share.
Every input either loads / is answered, or is refused with the project's own error (SceneError,
CommandError, a refused Result): never another exception, never a long echo, never slow.

`make test` runs a short seeded version; `make fuzz` runs the long one (LINKAGE_FUZZ=long:
thousands of examples per test, random seeds)."""

from __future__ import annotations

import math
import os
import time

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scenes import CONFIG, raw

from linkage_ros.core.errors import ECHO_CHARS, CommandError, SceneError
from linkage_ros.core.model import Scene
from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.request_checks import max_request_names, request_values

LONG = os.environ.get('LINKAGE_FUZZ') == 'long'
FUZZ = settings(
    max_examples=5000 if LONG else 100,
    derandomize=not LONG,  # the short run is the same every time
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
STEMS = sorted(p.stem for p in CONFIG.glob('*.yaml'))

scalars = (
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**30), max_value=10**30)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=30)
)
values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=12), inner, max_size=5)
    ),
    max_leaves=30,
)


def load_or_refuse(path) -> None:
    t0 = time.perf_counter()
    try:
        Scene.from_yaml(path)
    except SceneError as exc:
        text = str(exc)
        # the file name, the key and an echo of at most ECHO_CHARS: bounded whatever the input
        assert len(text) < len(str(path)) + 600, text[:300]
        if '(got ' in text:
            assert len(text.rsplit('(got ', 1)[1]) <= ECHO_CHARS + 1, text[-200:]
    assert time.perf_counter() - t0 < 5.0  # no hang (not a speed target)


@FUZZ
@given(st.binary(max_size=3000))
def test_any_bytes_load_or_are_refused(tmp_path_factory, data):
    path = tmp_path_factory.mktemp('bytes') / 'scene.yaml'
    path.write_bytes(data)
    load_or_refuse(path)


@FUZZ
@given(values)
def test_any_yaml_structure_loads_or_is_refused(tmp_path_factory, doc):
    path = tmp_path_factory.mktemp('yaml') / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    load_or_refuse(path)


@FUZZ
@given(st.sampled_from(STEMS), st.data())
def test_a_shipped_scene_with_one_value_replaced_loads_or_is_refused(tmp_path_factory, stem, data):
    doc = raw(stem)
    # walk to a random mapping entry or list item and replace it with a random value
    node = doc
    for _ in range(data.draw(st.integers(0, 3))):
        if isinstance(node, dict) and node:
            key = data.draw(st.sampled_from(sorted(node, key=str)))
            if not isinstance(node[key], dict | list):
                break
            node = node[key]
        elif isinstance(node, list) and node:
            nxt = node[data.draw(st.integers(0, len(node) - 1))]
            if not isinstance(nxt, dict | list):
                break
            node = nxt
    if isinstance(node, dict) and node:
        node[data.draw(st.sampled_from(sorted(node, key=str)))] = data.draw(values)
    elif isinstance(node, list) and node:
        node[data.draw(st.integers(0, len(node) - 1))] = data.draw(values)
    path = tmp_path_factory.mktemp('mut') / f'{stem}.yaml'
    path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    load_or_refuse(path)


ENGINES: dict[str, Engine] = {}


def engine(stem: str) -> Engine:
    if stem not in ENGINES:
        mech = Scene.from_yaml(CONFIG / f'{stem}.yaml').mechanism
        ENGINES[stem] = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    return ENGINES[stem]


names = st.text(max_size=20) | st.sampled_from(
    ['crank', 'B', 'rocker', 'Z1', 'Z2', 'Z3', 'point:D', 'theta_A', 'theta_C', '\x00', '']
)


@FUZZ
@given(
    st.sampled_from(['four_bar', 'excavator', 'plagiograph', 'slider_crank']),
    st.sampled_from(['command', 'target']),
    st.lists(names, max_size=8),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=8),
)
def test_requests_are_answered_or_refused_by_name(stem, kind, req_names, positions):
    """The node's path (request check, then the engine) and the bag's share these: an answer
    or a refusal with a reason, the state unchanged by a refusal, a finite answer."""
    e = engine(stem)
    before = e.last
    try:
        vals = request_values(req_names, positions, max_request_names(e.mech))
    except CommandError as exc:
        assert str(exc) and len(str(exc)) < 400
        return
    r = e.command(vals) if kind == 'command' else e.target(vals)
    if r.success:
        assert all(math.isfinite(v) for v in r.joints.values())
        assert r.residual is not None and r.residual < 1e-6
    else:
        assert r.reason and 'internal' not in r.reason
        assert len(r.reason) < 2000
        assert e.last is before
