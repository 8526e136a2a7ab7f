#!/usr/bin/env python3
"""cuSPARSE SpMV (through PyTorch) on the matrix that yasps-spmv-bench
exported, for the comparison with the runtime's SpMV.

    yasps-spmv-bench bunny-19k.msh --export DIR    # prints yasps' GPU SpMV
    python3 bench/gpu_cusparse.py DIR [--yasps-ms T] [--repeat 200] [--json PATH]

Loads the whole matrix (both triangles) as CSR, converts it to BSR with
3x3 blocks, checks both products against the exported y = H x, and times
``matrix @ x`` on the GPU (cuSPARSE's CSR and BSR SpMV), float64. With
``--yasps-ms`` (yasps' time from yasps-spmv-bench) it prints the ratios.
``--device cpu`` runs the same code on the CPU (to check the script without
a GPU; the times then say nothing about cuSPARSE).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sparse
import torch

import benchlib  # noqa: E402

benchlib.use_this_checkout()
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import per_call  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dir", type=Path)
    parser.add_argument("--yasps-ms", type=float, default=None)
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument("--device", default="cuda")
    add_json_argument(parser, "gpu_cusparse")
    args = parser.parse_args()
    results = Results("gpu_cusparse")
    # PyTorch warns that its sparse tensors are in beta.
    warnings.filterwarnings("ignore", category=UserWarning)
    load = {k: np.load(args.dir / f"{k}.npy")
            for k in ("indptr", "indices", "values", "x", "y")}
    n = len(load["x"])
    csr = sparse.csr_matrix((load["values"], load["indices"], load["indptr"]),
                            shape=(n, n))
    bsr = csr.tobsr(blocksize=(3, 3))
    device = torch.device(args.device)
    finish = (lambda _: torch.cuda.synchronize()) if device.type == "cuda" \
        else (lambda _: None)
    x = torch.from_numpy(load["x"]).to(device)
    want = load["y"]
    matrices = {
        "CSR": torch.sparse_csr_tensor(
            torch.from_numpy(csr.indptr.astype(np.int64)),
            torch.from_numpy(csr.indices.astype(np.int64)),
            torch.from_numpy(csr.data), size=(n, n)).to(device),
        "BSR 3x3": torch.sparse_bsr_tensor(
            torch.from_numpy(bsr.indptr.astype(np.int64)),
            torch.from_numpy(bsr.indices.astype(np.int64)),
            torch.from_numpy(bsr.data), size=(n, n)).to(device),
    }
    name = torch.cuda.get_device_name() if device.type == "cuda" else "CPU"
    title = (f"cuSPARSE SpMV through PyTorch {torch.__version__} on {name}: "
             f"{n} DoFs, {csr.nnz} scalar non-zeros, {bsr.nnz // 9} 3x3 blocks "
             "(whole matrix)")
    print(title)
    results.values.update(device=name, torch=torch.__version__, dofs=n,
                          non_zeros=csr.nnz, blocks=bsr.nnz // 9,
                          repeat=args.repeat, yasps_ms=args.yasps_ms)
    # ms and the time against yasps' (none without --yasps-ms); a format
    # that could not run has neither.
    rows, not_run = [], []
    for label, matrix in matrices.items():
        try:
            got = (matrix @ x).cpu().numpy()
        except (RuntimeError, NotImplementedError) as err:
            print(f"  {label:8s} not run: {type(err).__name__}: {err}")
            rows.append([f"cuSPARSE {label}", None, None])
            not_run.append(f"{label} not run: {type(err).__name__}: {err}.")
            continue
        error = np.abs(got - want).max() / np.abs(want).max()
        assert error < 1e-10, f"{label}: product off by {error:.2e}"
        t = per_call(lambda: matrix @ x, args.repeat, finish)
        ms = t * 1e3
        against = ms / args.yasps_ms if args.yasps_ms else None
        rows.append([f"cuSPARSE {label}", ms, against])
        ratio = f"  ({against:.2f}x yasps)" if against is not None else ""
        print(f"  {label:8s} {ms:9.4f} ms{ratio}")
    results.table("spmv", ["same matrix, other SpMV", "time", "against yasps"],
                  rows, ["", "{:.4f} ms", "{:.2f}x yasps"],
                  " ".join([f"{title}; against yasps: the time over yasps' "
                            "(yasps-spmv-bench)."] + not_run))
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
