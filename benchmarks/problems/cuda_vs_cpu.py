"""Where do the FNO's CUDA answers leave the CPU's? (needs a CUDA device)

Builds the small pointwise FNO of ``tests/models/test_pointwise_queries.py`` (d = 2, two
outputs), in float64 and float32, with PyTorch's TF32 on and off, and prints for each:
the relative difference of its grid values on CUDA against the CPU, module by module
(forward hooks; the first module that differs), and the relative difference of DeepXDE's
second derivative ``dde.grad.hessian`` against the float64 CPU one.
docs/any_problem.md quotes it (an H200).

Run it with::

    python benchmarks/problems/cuda_vs_cpu.py
"""
import deepxde as dde
import torch

import nh_operators as nh  # selects DeepXDE's PyTorch backend before deepxde loads
from nh_operators.models import cast_network
FNO = dict(n_modes=4, hidden_channels=4, n_layers=1, n_grid=12)


def pointwise(dtype=torch.float64):
    torch.manual_seed(0)
    net = nh.build_model("fno", "cpu", **FNO, query_coupled=False, query_dim=2, n_outputs=2)
    return cast_network(net, dtype).eval()


def data(dtype=torch.float64):
    g = torch.Generator().manual_seed(1)
    V = (torch.rand(2, 100, generator=g) * 4 - 2).to(dtype)
    x = torch.rand(5, 2, generator=g).to(dtype)
    return V, x

print("default device", torch.get_default_device(), "cudnn tf32", torch.backends.cudnn.allow_tf32,
      "matmul tf32", torch.backends.cuda.matmul.allow_tf32)


def trace(net, V):
    outs = {}
    hooks = [m.register_forward_hook(lambda mod, i, o, n=n: outs.__setitem__(n, o))
             for n, m in net.named_modules() if n]
    with torch.no_grad():
        y = net.grid_values(V)
    for h in hooks:
        h.remove()
    return y, outs


for dtype in (torch.float64, torch.float32):
    for tf32 in (True, False):
        torch.backends.cudnn.allow_tf32 = tf32
        torch.backends.cuda.matmul.allow_tf32 = tf32
        net = pointwise(dtype)
        V, x = data(dtype)
        ycpu, ocpu = trace(net, V)
        gpu = cast_network(net, dtype).cuda()
        print(dtype, "tf32", tf32, "parameter dtypes",
              sorted({str(p.dtype) for p in gpu.parameters()}))
        ygpu, ogpu = trace(gpu, V.cuda())
        rel = ((ygpu.cpu() - ycpu).abs().max() / ycpu.abs().max()).item()
        print("   grid_values rel diff", f"{rel:.2e}")
        first = None
        for name in ocpu:
            a, b = ocpu[name], ogpu.get(name)
            if not isinstance(a, torch.Tensor) or not isinstance(b, torch.Tensor):
                continue
            d = ((b.cpu() - a).abs().max() / (a.abs().max() + 1e-300)).item()
            if first is None and d > (1e-12 if dtype == torch.float64 else 1e-5):
                first = name
            print(f"   {name:60s} {str(a.dtype):15s} {d:.1e}")
        print("   first module off:", first)

for dtype in (torch.float64, torch.float32):
    for tf32 in (True, False):
        torch.backends.cudnn.allow_tf32 = tf32
        torch.backends.cuda.matmul.allow_tf32 = tf32
        net = pointwise()
        V, x = data()
        xg = x.clone().requires_grad_()
        dde.grad.clear()
        ref = dde.grad.hessian(net((V, xg))[0], xg, component=1, i=1, j=0).detach()
        dev = "cuda" if torch.cuda.is_available() else "cpu"
        gpu = cast_network(net, dtype).to(dev)
        xc = x.to(dev, dtype).requires_grad_()
        dde.grad.clear()
        H = dde.grad.hessian(gpu((V.to(dev, dtype), xc))[0], xc, component=1, i=1, j=0)
        print("hessian", dtype, "tf32", tf32, "max |H - ref| / max |ref|",
              f"{((H.cpu().double() - ref).abs().max() / ref.abs().max()).item():.2e}")
