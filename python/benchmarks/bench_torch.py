"""Speed of turbid.torch (issue 35): a batch forward + backward through the full differentiable
model, and forward-only throughput against turbid.render (C++) in the same run.

Run: PYTHONPATH=build/python python3 python/benchmarks/bench_torch.py [--batch 64] [--size 256]
     [--threads 2] [--rounds 3] [--chunk-images N] [--compare-chunks [0,auto,...]]

The batch: seafloor (built-in) cut to size x size, per-image water (beta, B_inf, E_A), lamp power
and position with requires_grad, the paper model with its lamp and veil, eq. 7's PSF (T = 4: the
separable Gaussian; --learn-psf makes T and q tensors, which takes the 2-D kernel), sensor noise
(the renderer's normals) and no camera quantiser (a training loss reads linear light). Snow off on
both sides. Times are wall clock (median of the rounds) with torch and turbid limited to --threads;
CPU time of the process is printed beside them (the machine may be shared), and the system
CPU time and page faults within it: with glibc's malloc most of the system time is the kernel
zeroing fresh pages for each large temporary; a caching allocator removes it (e.g.
GLIBC_TUNABLES=glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=4294967295, or jemalloc /
tcmalloc by LD_PRELOAD, as PyTorch's CPU performance guide recommends). render's default chunks
of images (chunk_images) keep the temporaries below glibc's mmap threshold instead;
--compare-chunks times the forward + backward alone for each chunk_images setting given (0: one
pass, auto: the default), alternating round by round.
"""
import argparse
import resource
import time

import numpy as np
import torch

import turbid
import turbid.torch as tt


def scene_crop(size):
    scale = max(size / 480.0, size / 640.0) * 1.01
    scene = turbid.Scene.builtin("seafloor", min(scale, 1.0))
    c = scene.camera
    image = np.ascontiguousarray(scene.image[:size, :size])
    depth = np.ascontiguousarray(scene.depth[:size, :size])
    normals = np.ascontiguousarray(scene.normals[:size, :size])
    return turbid.Scene.from_arrays(image, depth, c["fx"], c["fy"], c["cx"], c["cy"],
                                    normals=normals), image, depth, normals, c


def timed(fn, rounds, counts=None):
    """Median wall and process CPU seconds of fn over the rounds; ``counts`` (a dict) receives the
    median system-CPU seconds and minor page faults per round (fresh memory the allocator took
    from the kernel: glibc returns blocks above 32 MB to the system on free, so every large
    temporary tensor is faulted in anew)."""
    walls, cpus, syss, faults = [], [], [], []
    for _ in range(rounds):
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        w, p = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - p)
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        syss.append(r1.ru_stime - r0.ru_stime)
        faults.append(r1.ru_minflt - r0.ru_minflt)
    if counts is not None:
        counts.update(sys=float(np.median(syss)), faults=int(np.median(faults)))
    return float(np.median(walls)), float(np.median(cpus))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--learn-psf", action="store_true")
    ap.add_argument("--no-noise", action="store_true")
    ap.add_argument("--snow", action="store_true",
                    help="marine snow on (the renderer's default particles), in both renders")
    ap.add_argument("--cache-memory", action="store_true",
                    help="turbid.torch.cache_host_memory(): keep freed memory for reuse")
    ap.add_argument("--veil", default="paper", choices=["paper", "single_scatter"],
                    help="the lamps' veil: eq. 2's or the single-scatter integral")
    ap.add_argument("--noise", default="turbid", choices=["turbid", "torch"],
                    help="the normals of the sensor noise: the renderer's stream or torch's")
    ap.add_argument("--chunk-images", type=int, default=None,
                    help="render's chunk_images (default: automatic; 0: the whole batch at once)")
    ap.add_argument("--compare-chunks", nargs="?", const="0,auto", default=None,
                    help="forward + backward with these chunk_images (default 0,auto: one pass "
                    "and automatic chunks), alternating round by round; nothing else")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    if args.cache_memory and not tt.cache_host_memory():
        print("cache_host_memory: no glibc mallopt here")
    turbid.set_num_threads(args.threads)
    n, s = args.batch, args.size
    scene, image, depth, normals, c = scene_crop(s)
    rho = torch.from_numpy(image).permute(2, 0, 1)[None].expand(n, -1, -1, -1).contiguous()
    d = torch.from_numpy(depth)[None, None].expand(n, -1, -1, -1).contiguous()
    nrm = torch.from_numpy(normals).permute(2, 0, 1)[None].expand(n, -1, -1, -1).contiguous()
    K = torch.tensor([[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]])
    g = torch.Generator().manual_seed(0)
    leaves = {
        "beta": (0.2 + torch.rand(n, 3, generator=g)).requires_grad_(),
        "binf": (0.3 * torch.rand(n, 3, generator=g)).requires_grad_(),
        "ambient": (0.1 + 0.1 * torch.rand(n, 3, generator=g)).requires_grad_(),
        "power": (4.0 + 4.0 * torch.rand(n, generator=g)).requires_grad_(),
        "position": (torch.tensor([0.0, 0.25, 0.0]) + 0.1 * torch.rand(n, 3, generator=g))
        .requires_grad_(),
        "T": torch.tensor(4.0, requires_grad=args.learn_psf),
        "q": torch.tensor(0.9, requires_grad=args.learn_psf),
    }

    def params(v):
        return {"water": {"beta_rgb_per_m": v["beta"], "backscatter": True,
                          "backscatter_rgb": v["binf"], "ambient_rgb": v["ambient"]},
                "light": {"lights": [{"power": v["power"], "position_in_camera_m": v["position"]}]},
                "psf": {"optical_thickness": v["T"], "forward_scatter": v["q"]},
                "snow": {"enabled": args.snow}, "sensor": {"enabled": not args.no_noise},
                "veil": args.veil}

    def forward_backward():
        for leaf in leaves.values():
            leaf.grad = None
        out = tt.render(rho, d, K, params(leaves), seed=1, normals=nrm, noise=args.noise,
                        chunk_images=chunk[0])
        out.square().mean().backward()

    def forward():
        with torch.no_grad():
            tt.render(rho, d, K, params(leaves), seed=1, normals=nrm, noise=args.noise,
                      chunk_images=chunk[0])

    cpp_params = [{"water": {"beta_rgb_per_m": leaves["beta"][i].tolist(), "backscatter": True,
                             "backscatter_rgb": leaves["binf"][i].tolist(),
                             "ambient_rgb": leaves["ambient"][i].tolist()},
                   "light": {"lights": [{"power": float(leaves["power"][i]),
                                         "position_in_camera_m": leaves["position"][i].tolist()}]},
                   "snow": {"enabled": args.snow}, "sensor": {"enabled": not args.no_noise},
                   "camera": {"bit_depth": 32}, "veil": args.veil} for i in range(n)]

    def cpp():
        for i in range(n):
            turbid.render(scene, cpp_params[i], seed=1 + i).image

    chunk = [args.chunk_images]
    if args.compare_chunks:
        compare_chunks(forward_backward, chunk, args.rounds, [
            None if x == "auto" else int(x) for x in args.compare_chunks.split(",")])
        return
    forward_backward()  # warm-up (allocator, tables)
    fb_counts, fw_counts = {}, {}
    fb = timed(forward_backward, args.rounds, fb_counts)
    fw = timed(forward, args.rounds, fw_counts)
    cp = timed(cpp, args.rounds)
    pixels = n * s * s
    print("batch %d x 3 x %d x %d, %d threads, noise %s, PSF %s, veil %s, snow %s%s" % (
        n, s, s, args.threads, "off" if args.no_noise else "on (%s normals)" % args.noise,
        "learned (2-D kernel)" if args.learn_psf else "fixed (separable)", args.veil,
        "on" if args.snow else "off", ", freed memory cached" if args.cache_memory else ""))
    print("torch forward + backward: %.3f s wall (CPU %.3f s); goal <= 2 s" % fb)
    print("torch forward:            %.3f s wall (CPU %.3f s), %.1f Mpx/s" % (
        fw[0], fw[1], pixels / fw[0] / 1e6))
    print("  of which system CPU (page faults of fresh memory): forward + backward %.3f s "
          "(%d faults), forward %.3f s (%d faults)" % (fb_counts["sys"], fb_counts["faults"],
                                                       fw_counts["sys"], fw_counts["faults"]))
    print("turbid.render (C++):      %.3f s wall (CPU %.3f s), %.1f Mpx/s" % (
        cp[0], cp[1], pixels / cp[0] / 1e6))
    print("forward throughput torch / C++: %.2f (wall), %.2f (CPU)" % (cp[0] / fw[0],
                                                                     cp[1] / fw[1]))
    stages(rho, leaves, params, args)


def compare_chunks(forward_backward, chunk, rounds, settings):
    """Forward + backward with each chunk_images setting (0: one pass, None: automatic),
    alternating round by round (the machine's load falls on all alike): medians of wall, CPU,
    system CPU and minor page faults."""
    results = {s: [] for s in settings}
    for setting in settings:  # warm-up
        chunk[0] = setting
        forward_backward()
    for _ in range(rounds):
        for setting in settings:
            chunk[0] = setting
            counts = {}
            wall, cpu = timed(forward_backward, 1, counts)
            results[setting].append((wall, cpu, counts["sys"], counts["faults"]))
    for setting in settings:
        name = {0: "one pass", None: "automatic chunks"}.get(setting, "chunks of %s" % setting)
        wall, cpu, sys_, faults = np.median(np.array(results[setting]), axis=0)
        print("forward + backward, chunk_images=%-5s (%s): %.3f s wall, CPU %.3f s, system %.3f s, "
              "%d page faults" % (setting, name, wall, cpu, sys_, faults))


def stages(rho, leaves, params, args):
    """Where the time goes, and what a fused kernel would gain: the PSF (2R + 1 taps per pass,
    two passes) against a single elementwise pass over the same tensor (one read, one write:
    the floor a fused blur approaches), forward and forward + backward; the noise's normals."""
    P = tt.resolve(params(leaves))
    kernel = tt.psf_kernel(P, rho, rho.shape[0])
    lit = rho.clone().requires_grad_()
    scale = torch.tensor(1.01, requires_grad=True)

    def psf_fb():
        lit.grad = None
        tt.apply_psf(lit, kernel).sum().backward()

    def pass_fb():
        lit.grad = None
        (lit * scale).sum().backward()

    psf_f = timed(lambda: tt.apply_psf(lit.detach(), kernel), args.rounds)
    one_f = timed(lambda: lit.detach() * 1.01, args.rounds)
    print("PSF (R = %d, separable): forward %.3f s wall (CPU %.3f), forward + backward %.3f s "
          "(CPU %.3f)" % ((kernel[0].shape[-1] - 1) // 2, psf_f[0], psf_f[1], *timed(psf_fb, args.rounds)))
    one_fb = timed(pass_fb, args.rounds)
    print("one elementwise pass:    forward %.3f s wall (CPU %.3f), forward + backward %.3f s "
          "(CPU %.3f): a fused PSF kernel would approach this" % (*one_f, *one_fb))
    n, c, h, w = rho.shape
    z = timed(lambda: tt.standard_normals(1, n * c * h * w), 1)
    g = torch.Generator().manual_seed(0)
    r = timed(lambda: torch.randn(n, c, h, w, generator=g), args.rounds)
    print("noise normals: renderer's stream (NumPy) %.3f s wall (CPU %.3f), torch.randn %.3f s "
          "(CPU %.3f)" % (*z, *r))
    from turbid._torch_noise import _normals_of_seed
    nat = timed(lambda: [_normals_of_seed(i, c * h * w) for i in range(n)], args.rounds)
    print("noise normals: the renderer's RandomNormals (turbid._turbid, used when built) "
          "%.3f s wall (CPU %.3f)" % nat)
    veil_stage(rho, leaves, params, args)


def veil_stage(rho, leaves, params, args):
    """The single-scatter veil alone (tables on the ray grid + per-pixel interpolation), forward
    and forward + backward, against one elementwise pass."""
    p = params(leaves)
    p["veil"] = "single_scatter"
    scene, _, depth, _, c = scene_crop(args.size)
    d = torch.from_numpy(depth)[None, None].expand(rho.shape[0], -1, -1, -1)
    K = torch.tensor([[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]])
    r = tt.range_from_depth(d, K)
    n, ch = rho.shape[:2]
    P = tt.resolve(p)
    beta = P.channels("water", "beta_rgb_per_m", "beta_gray_per_m", rho, n, ch)

    def veil():
        return tt._single_scatter(P, K, r, beta, rho, n, ch)

    def veil_fb():
        for leaf in leaves.values():
            leaf.grad = None
        veil().sum().backward()

    with torch.no_grad():
        f = timed(veil, args.rounds)
    print("single-scatter veil alone: forward %.3f s wall (CPU %.3f), forward + backward %.3f s "
          "(CPU %.3f)" % (*f, *timed(veil_fb, args.rounds)))


if __name__ == "__main__":
    main()
