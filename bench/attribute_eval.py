#!/usr/bin/env python3
"""Evaluating one attribute on 80k tets: yasps against NumPy and a C++ loop.

The attribute is the deformation gradient F = Ds * Dm^-1 of every tet of
../shared/data/bunny-19k.msh (79,935 tets), with Ds gathered through a JOIN
of the vertex positions. Prints cold compile time, warm start time (kernel
from the on-disk cache in a new process), and evaluation time on one thread
against the same computation written in NumPy and in C++ (-O3
-march=native, built here). Ratios are what to compare across machines.

    python3 bench/attribute_eval.py [--repeat 20] [--json PATH]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import yasps  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402
from benchlib.meshes import bunny  # noqa: E402


def build_scene():
    verts, tets = bunny("19k")
    rng = np.random.default_rng(0)
    x = verts + rng.normal(scale=1e-3, size=verts.shape)
    rest = verts[tets]                                   # (M, 4, 3)
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    dm_inv = np.linalg.inv(dm)
    s = yasps.scene("bench")
    m = s.addMesh("bunny")
    v = m.addPrimitive("vertices", numInstances=len(verts))
    t = m.addPrimitive("tets", numInstances=len(tets))
    v.addAttribute("x", rows=3, cols=1).updateValue(x)
    t.addConstant("DmInv", rows=3, cols=3).updateValue(dm_inv)
    t2v = t.addConnectivity("tet2v", v, tets, 4)
    p = t.addAttribute("x", through=t2v, source=v["x"])
    ds = yasps.hstack([(p.row(k) - p.row(0)).T for k in (1, 2, 3)])
    F = t.addAttribute("F", computed_attribute=ds * t["DmInv"])
    return s, F, x, tets, dm_inv


def first_compute_in_new_process(cache: str) -> dict:
    """Runs one compute() in a fresh interpreter; returns its timings."""
    code = f"""
import json, sys, time
sys.argv = ['x']
sys.path.insert(0, {str(HERE)!r})
import attribute_eval as b
s, F, *_ = b.build_scene()
t0 = time.perf_counter()
r = F.compute(threads=1)
print(json.dumps(dict(r.stats, first_compute=time.perf_counter() - t0)))
"""
    env = dict(os.environ, YASPS_CACHE_DIR=cache)
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def build_cpp(workdir: Path) -> ctypes.CDLL:
    lib = workdir / "deformation_gradient.so"
    subprocess.run(["g++", "-O3", "-march=native", "-shared", "-fPIC",
                    str(HERE / "cpp" / "deformation_gradient.cpp"), "-o",
                    str(lib)], check=True)
    return ctypes.CDLL(str(lib))




def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=20)
    add_json_argument(parser, "attribute_eval")
    args = parser.parse_args()
    results = Results("attribute_eval")

    with tempfile.TemporaryDirectory() as tmp:
        cache = str(Path(tmp) / "cache")
        cold = first_compute_in_new_process(cache)
        warm = first_compute_in_new_process(cache)
        assert warm["from_disk"], "second process did not use the disk cache"

        yasps.config.cache_dir = cache
        s, F, x, tets, dm_inv = build_scene()
        result = F.compute(threads=1).value

        # The kernel alone, as the runtime launches it.
        from yasps.compiler.cpu import compile_cpu
        from yasps.ir import emit_scene
        from yasps.runtime.cpu import launch
        from yasps.runtime.inputs import host_input
        from yasps.compiler.params import ArgumentKind
        path = "@bunny::@tets::@F"
        library = compile_cpu(emit_scene(s), [path], s.name)
        out = np.empty(len(tets) * 9)
        buffers = [out if a.kind is ArgumentKind.out else host_input(s, a)
                   for a in library.kernel(path).arguments]
        kernel = median(lambda: launch(library, path, len(tets), buffers, 1),
                        args.repeat)
        end_to_end = median(lambda: F.compute(threads=1), args.repeat)

        # NumPy: gather, differences, batched 3x3 products.
        def numpy_f():
            p = x[tets]
            ds = np.stack([p[:, k] - p[:, 0] for k in (1, 2, 3)], axis=2)
            return ds @ dm_inv
        reference = numpy_f()
        np.testing.assert_allclose(result, reference, rtol=1e-12, atol=1e-12)
        numpy_time = median(numpy_f, args.repeat)

        cpp = build_cpp(Path(tmp))
        x_cm = np.ascontiguousarray(x)            # 3x1: row- = column-major
        dm_cm = np.ascontiguousarray(np.transpose(dm_inv, (0, 2, 1))).reshape(-1)
        cpp_out = np.empty(len(tets) * 9)
        ptr = lambda a: a.ctypes.data_as(ctypes.c_void_p)
        call = lambda: cpp.deformation_gradient(ptr(x_cm), ptr(tets), ptr(dm_cm),
                                                ptr(cpp_out),
                                                ctypes.c_int64(len(tets)))
        call()
        np.testing.assert_allclose(cpp_out, out, rtol=1e-12, atol=1e-12)
        cpp_time = median(call, args.repeat)

    title = (f"deformation gradient of {len(tets)} tets (bunny-19k), one "
             f"thread, median of {args.repeat}")
    results.values.update(tets=len(tets), repeat=args.repeat, cold=cold,
                          warm=warm)
    # Milliseconds; a warm start loads the object where a cold one lowers
    # and generates code.
    startup = [
        ["cold compile (new process, empty cache)", cold["lower_seconds"] * 1e3,
         cold["codegen_seconds"] * 1e3, cold["first_compute"] * 1e3],
        ["warm start (new process, disk cache)", None,
         warm["codegen_seconds"] * 1e3, warm["first_compute"] * 1e3]]
    results.table("startup", ["start", "lower", "codegen / load",
                              "first compute()"], startup,
                  ["", "{:.1f} ms", "{:.1f} ms", "{:.1f} ms"],
                  f"{title[0].upper()}{title[1:]}.")
    times = [[name, t * 1e3, t / cpp_time]
             for name, t in [("yasps kernel", kernel),
                             ("yasps compute()", end_to_end),
                             ("NumPy", numpy_time),
                             ("C++ loop (-O3)", cpp_time)]]
    results.table("times", ["", "time", "vs C++"], times,
                  ["", "{:.2f} ms", "{:.2f}x"],
                  f"{title[0].upper()}{title[1:]}.")

    print(title)
    (_, lower, codegen, cold_first), (_, _, load, warm_first) = startup
    print(f"  cold compile (new process, empty cache): lower {lower:.1f} ms + "
          f"codegen {codegen:.1f} ms; first compute() {cold_first:.1f} ms")
    print(f"  warm start (new process, disk cache):    load {load:.1f} ms; "
          f"first compute() {warm_first:.1f} ms")
    print(f"  {'':24s}{'time':>10s}{'vs C++':>10s}")
    for name, ms, ratio in times:
        print(f"  {name:24s}{ms:8.2f} ms{ratio:9.2f}x")
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
