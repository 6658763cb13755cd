"""The particle axis is sharded over all local devices, with the same counts as on one device.

Two CPU devices are forced in a fresh process (the flag must be set before JAX starts).
"""
import json
import os
import subprocess
import sys
from pathlib import Path

SCRIPT = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import jax
import numpy as np
from ipf_jax import jax_setup
from ipf_jax.likelihood.scorer import Scorer, make_observation
from test_likelihood import SHAPE, U, make_scene

jax_setup.configure()
cams, q, masks, particles = make_scene()  # the shapes of test_likelihood: cached compiles
obs = make_observation(list(masks[2]))
split = Scorer(cams, SHAPE, U, chunk=15)  # rounded up to a multiple of the 2 devices
alone = Scorer(cams, SHAPE, U, chunk=16, devices=jax.devices()[:1])
caps, _ = split.geometry(particles)
print(json.dumps({
    "devices": len(jax.devices()),
    "chunk": split.chunk,
    "spread": len(jax.tree.leaves(caps[0][0])[0].sharding.device_set),
    "equal": bool(np.array_equal(split.counts(particles, obs), alone.counts(particles, obs))),
}))
"""


def test_two_devices_share_the_particles_and_agree_with_one():
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2", JAX_PLATFORMS="cpu")
    done = subprocess.run([sys.executable, "-c", SCRIPT, str(Path(__file__).parent)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out == {"devices": 2, "chunk": 16, "spread": 2, "equal": True}
