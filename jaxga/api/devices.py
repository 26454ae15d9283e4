"""Devices and processes for one experiment, set up before the first JAX computation
(docs/devices.md): every core of this machine as a CPU device, a number of local devices,
several processes joined through ``jax.distributed``, and the devices a run shards over.

The functions live with the drivers' machinery (:mod:`jaxga._runtime.parallel`); this
module is their public name::

    import jaxga.api.devices
    jaxga.api.devices.use_all_cores()   # or set_local_devices(n), before any JAX computation
"""

from __future__ import annotations

from jaxga._runtime.parallel import (
    initialize,
    process_count,
    process_index,
    run_devices,
    set_local_devices,
    use_all_cores,
)

__all__ = ["initialize", "process_count", "process_index", "run_devices",
           "set_local_devices", "use_all_cores"]
