"""The machinery behind jaxga's drivers (private: what the public API in :mod:`jaxga.api`
and the tools use, with no promise of stability to users).

- :mod:`~jaxga._runtime.programs`: the compiled programs of a batch of runs, cached per
  shape, traced from the methods of :class:`jaxga.engine.run.PureGA`;
- :mod:`~jaxga._runtime.executables`: the store of compiled programs;
- :mod:`~jaxga._runtime.compilation_cache`: the store's folder and JAX's persistent
  compilation cache (:func:`jaxga.configure`);
- :mod:`~jaxga._runtime.lowering`: how jaxga's own programs are lowered (Threefry without
  a loop on the CPU, scoped to them);
- :mod:`~jaxga._runtime.calls`: a request's runs as calls of the compiled programs;
- :mod:`~jaxga._runtime.memory`: the memory a call needs, checked before it runs;
- :mod:`~jaxga._runtime.seeds`: accepted seeds, their keys and sharding;
- :mod:`~jaxga._runtime.parallel`: every core, and several processes, for one experiment;
- :mod:`~jaxga._runtime.size_classes`: maps padded to a size class share programs;
- :mod:`~jaxga._runtime.references`: the exact references every result is compared with;
- :mod:`~jaxga._runtime.timeline`: the timed phases a user waits for;
- :mod:`~jaxga._runtime.jax_settings` and :mod:`~jaxga._runtime.device_probe`: the JAX
  settings and backends jaxga refuses, and the probe of a backend against the CPU.
"""
