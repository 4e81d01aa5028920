"""``oclshade bench``: the device-portability benchmark.

The same kernels on every OpenCL device: each device's measured roofline
(:mod:`.roofline`), every kernel family timed through the public Python API
on generated inputs (:mod:`.suite`, which also states the bytes / flops model
of each case), whether the outputs agree across devices and Pennycook's
performance portability (:mod:`.portability`), reports (:mod:`.report`) and
the comparison with an earlier run (:mod:`.compare`); the command is
:mod:`.cli`.

``bench.json`` (schema ``"oclshade-bench/1"``)::

    schema, command, sizes ("full" | "quick" | "tiny"), reps
    machine:   date (UTC ISO 8601), cpu, cores, os, python, pyopencl, numpy, oclshade
    families:  the kernel families, in order
    cases:     [{id ("family/variant"), family, exact (outputs must match across devices)}]
    devices:   [{key ("platform / device"), index, platform, platform_version, name,
                 version (PoCL: names the LLVM target), driver_version, type, compute_units,
                 max_clock_mhz, global_mem_bytes, max_alloc_bytes,
                 roofline: {bandwidth_gbs, gflops, copy_buffer_bytes, probes: {variant: rate}} | null,
                 error (roofline probes) | null,
                 tuning: {family: {values, source}},
                 cases: {id: {family, exact, what, unit, items, input_digest, reps, times_ms,
                              warm_up_ms, min_ms, median_ms, throughput_per_s (items / min time),
                              bytes, flops, roofline_ms, roofline_fraction (roofline_ms / min_ms),
                              digest (sha256 hex of the outputs), error (null, or why it failed)}}}]
    agreement:   {id: {must_match, status ("identical" | "differs" | "single device" |
                       "incomplete"), digests: {device key: digest | null}}}
    portability: {families: {family: {pp, efficiency: {device key: e | null}}},
                  cases: {id: {pp, efficiency: {device key: e | null}}}}
    compare:     {against, against_date, threshold_pct, regressions: [{device, case, kind
                  ("slower" | "digest" | "failed"), detail}], notes: [...]}   (with --compare only)
"""
