"""What this machine can do, and the benchmark-only tricks that make it look like another one.

- :mod:`~morf.machine.flags`: the CPU's feature flags as ``/proc/cpuinfo`` lists them;
- :mod:`~morf.machine.cpuid_mask` (+ ``cpuid_mask.c``): run a benchmark as a smaller CPU class;
- :mod:`~morf.machine.amx_permission`: whether the kernel grants AMX, and refusing it;
- :mod:`~morf.machine.features`: the flags as this process sees them (a mask applied), native
  bfloat16, the summary a benchmark record carries;
- :mod:`~morf.machine.compiled`: whether numba's compiled loops can run.

Imports go one way (flags <- cpuid_mask <- features -> amx_permission), and the package sits below
the stages: the player and the CLI never import it when they start, only where a probe is asked.
This file imports nothing, so asking for one probe loads only that probe's module.
"""
