"""Fixtures shared by the node test files of this folder.

Every module that talks over DDS draws its own random ROS domain at import
(``DOMAIN_ID = random_domain_id()``, test/ros_harness.py): the ``ros`` harness here is made on
the requesting module's DOMAIN_ID (and named after its HARNESS_NAME, if it has one), and the
nodes the fixtures start join that domain, so each module stays isolated from the others and
from parallel runs. A module that defines a fixture of the same name (``ros``, ``four_bar``)
uses its own.

Module-scoped fixtures start one node process per module that uses them.
"""

from __future__ import annotations

import adversary_helpers
import node_helpers
import pytest
from ros_harness import RosHarness
from scenes import CONFIG


@pytest.fixture(scope='module')
def ros(request):
    """The test side on the module's own domain."""
    module = request.module
    harness = RosHarness(module.DOMAIN_ID, name=getattr(module, 'HARNESS_NAME', 'linkage_test'))
    yield harness
    harness.close()


# ---- nodes served from a subprocess (node_helpers) ------------------------------------------


@pytest.fixture(scope='module')
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp('linkage_node')


@pytest.fixture(scope='module')
def four_bar(ros, workdir):
    scene = CONFIG / 'four_bar.yaml'
    served, proc = node_helpers.start_served(
        ros, workdir, 'four_bar', scene, node_helpers.joint_state(['crank'], [1.2])
    )
    served.oracle = node_helpers.FourBarOracle(scene)
    yield served
    node_helpers.finish(proc)


@pytest.fixture(scope='module')
def three_dof(ros, workdir):
    scene = CONFIG / 'excavator.yaml'
    served, proc = node_helpers.start_served(
        ros,
        workdir,
        'three_dof',
        scene,
        node_helpers.mid_joint_state(scene),
        params={'target_point_hold': ['bucket']},
    )
    yield served
    node_helpers.finish(proc)


# ---- a node in this process (adversary_helpers) ----------------------------------------------


@pytest.fixture
def serve(ros):
    made = []

    def make(**params):
        s = adversary_helpers.Served(ros, params)
        made.append(s)
        return s

    yield make
    for s in made:
        s.close()
