"""C99 source of an exported policy: ``policy.h`` / ``policy.c`` (written by :mod:`spine_gym.agents.export`).

The generated code has the weights and the normaliser's statistics as ``static const float``
arrays, uses no heap and no library but ``tanhf`` of ``<math.h>`` (link with ``-lm``; a policy
without tanh layers needs no libm), and computes in float32 what
:mod:`spine_gym.agents.numpy_policy` computes (its docstring has the formulas):

* ``void policy_act(const float *input, float *act)`` — the network on its input
  (``POLICY_N_INPUT`` floats: the env's observation followed by the memories' features),
  ``POLICY_N_ACT`` actions out. Normalisation and the output stage are inside.
* for a policy with observation memories (``POLICY_HAS_STATE`` defined): ``policy_state_t``,
  ``void policy_reset(policy_state_t *s)`` (at an episode's start) and
  ``void policy_step(policy_state_t *s, const float *obs, float *act)`` on the env's observation
  (``POLICY_N_OBS`` floats). The integral is kept in double, as in :mod:`spine_gym.agents.observations`.

Compile with ``cc -std=c99 -O2 -c policy.c`` (ISO C mode: no contraction into fused multiply-adds,
so the integral's update is the same double arithmetic as NumPy's). :func:`compile_driver` builds
a test and timing program around it (:data:`DRIVER_SOURCE`).
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np

__all__ = ["c_sources", "write_c", "DRIVER_SOURCE", "compile_driver"]


def _f(v) -> str:
    """A float32 literal that round-trips (9 significant digits)."""
    return f"{float(np.float32(v)):.8e}f"


def _d(v) -> str:
    return f"{float(v):.17e}"


def _array(name: str, values, ctype: str = "float") -> str:
    vals = np.asarray(values).ravel()
    fmt = _f if ctype == "float" else _d
    rows = [", ".join(fmt(v) for v in vals[i : i + 6]) for i in range(0, len(vals), 6)]
    return f"static const {ctype} {name}[{len(vals)}] = {{\n    " + ",\n    ".join(rows) + "\n};\n"


def _header(spec: dict, guard: str) -> str:
    lines = [
        f"/* {spec['algo']} policy of {spec['env_id']}, exported by python -m spine_gym.agents.export from",
        f"   {spec['source'] or 'an in-memory model'}; generated, do not edit",
        "   (policy.json says what the numbers mean). */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        f"#define POLICY_N_OBS {spec['n_obs']}",
        f"#define POLICY_N_INPUT {spec['n_input']}",
        f"#define POLICY_N_ACT {spec['n_act']}",
        "",
        "/* the action for the network's input (env observation ++ memory features),",
        "   normalisation included */",
        "void policy_act(const float *input, float *act);",
    ]
    if spec["features"]:
        members = []
        for i, f in enumerate(spec["features"]):
            if f["kind"] == "integral":
                members.append(f"    double integral{i}[{f['size']}];")
            else:
                width = f["size"] // f["frames"]
                members.append(f"    float history{i}[{(f['frames'] + 1) * width}];")
        lines += [
            "",
            "#define POLICY_HAS_STATE 1",
            "typedef struct {",
            *members,
            "    int started;",
            "} policy_state_t;",
            "/* forget the memories: the next policy_step starts an episode */",
            "void policy_reset(policy_state_t *s);",
            "/* the action for the env's observation (POLICY_N_OBS floats), advancing the memories */",
            "void policy_step(policy_state_t *s, const float *obs, float *act);",
        ]
    lines += ["", f"#endif /* {guard} */", ""]
    return "\n".join(lines)


def _act_function(arrays: dict, spec: dict) -> list[str]:
    net = spec["network"]
    width = max(net["sizes"])
    out = [
        "void policy_act(const float *input, float *act)",
        "{",
        f"    float a[{width}], b[{width}];",
        "    float *h = a, *z = b, *t;",
        "    int i;",
        "    for (i = 0; i < POLICY_N_INPUT; i++) {",
        "        float v = (input[i] - OBS_MEAN[i]) / OBS_STD[i];",
    ]
    if np.isfinite(arrays["clip_obs"]):
        out.append("        v = v < -CLIP_OBS ? -CLIP_OBS : (v > CLIP_OBS ? CLIP_OBS : v);")
    out += ["        h[i] = v;", "    }"]
    sizes = net["sizes"]
    for k, act in enumerate(net["activations"]):
        out.append(f"    dense(W{k}, B{k}, {sizes[k + 1]}, {sizes[k]}, h, z);")
        if act == "tanh":
            out.append(f"    for (i = 0; i < {sizes[k + 1]}; i++) z[i] = tanhf(z[i]);")
        elif act == "relu":
            out.append(f"    for (i = 0; i < {sizes[k + 1]}; i++) z[i] = z[i] > 0.0f ? z[i] : 0.0f;")
        out.append("    t = h; h = z; z = t;")
    out.append("    for (i = 0; i < POLICY_N_ACT; i++) {")
    if net["output"] == "squash":
        out.append("        act[i] = ACT_LOW[i] + 0.5f * (tanhf(h[i]) + 1.0f) * (ACT_HIGH[i] - ACT_LOW[i]);")
    else:
        out.append(
            "        act[i] = h[i] < ACT_LOW[i] ? ACT_LOW[i] : (h[i] > ACT_HIGH[i] ? ACT_HIGH[i] : h[i]);"
        )
    out += ["    }", "}", ""]
    return out


def _step_function(spec: dict) -> list[str]:
    out = [
        "void policy_reset(policy_state_t *s) { s->started = 0; }",
        "",
        "void policy_step(policy_state_t *s, const float *obs, float *act)",
        "{",
        "    float x[POLICY_N_INPUT];",
        "    int i, k;",
        "    for (i = 0; i < POLICY_N_OBS; i++) x[i] = obs[i];",
    ]
    n = spec["n_obs"]
    for j, f in enumerate(spec["features"]):
        if f["kind"] == "integral":
            decay = 1.0 if f["tau"] == "inf" else math.exp(-float(f["dt"]) / float(f["tau"]))
            tr, tg, lim = f["tracked"][0], f["target"][0], float(f["limit"])
            out += [
                f"    /* integral of the error: I = clip(decay I + dt (x[{tg}+k] - x[{tr}+k]), +-limit) */",
                f"    for (k = 0; k < {f['size']}; k++) {{",
                f"        double v = s->started ? s->integral{j}[k] : 0.0;",
                f"        v = {_d(decay)} * v + {_d(f['dt'])} * ((double)x[{tg} + k] - (double)x[{tr} + k]);",
                f"        v = v < -{_d(lim)} ? -{_d(lim)} : (v > {_d(lim)} ? {_d(lim)} : v);",
                f"        s->integral{j}[k] = v;",
                f"        x[{n} + k] = (float)v;",
                "    }",
            ]
        else:
            frame = [i for a, b in f["ranges"] for i in range(a, b)]
            w, frames = len(frame), f["frames"]
            out += [
                f"    /* history: the {frames} frames before this one of inputs {frame}, newest first */",
                "    {",
                f"        static const int REC{j}[{w}] = {{{', '.join(map(str, frame))}}};",
                f"        float *m = s->history{j};",
                "        if (s->started) {",
                f"            for (k = {frames * w - 1}; k >= 0; k--) m[k + {w}] = m[k];",
                f"            for (k = 0; k < {w}; k++) m[k] = x[REC{j}[k]];",
                "        } else {",
                f"            for (k = 0; k < {(frames + 1) * w}; k++) m[k] = x[REC{j}[k % {w}]];",
                "        }",
                f"        for (k = 0; k < {frames * w}; k++) x[{n} + k] = m[{w} + k];",
                "    }",
            ]
        n += f["size"]
    out += ["    s->started = 1;", "    policy_act(x, act);", "}", ""]
    return out


def c_sources(arrays: dict, spec: dict, stem: str = "policy") -> tuple[str, str]:
    """``(header, source)`` C99 text of a bundle (see the module docstring)."""
    guard = f"{stem.upper()}_H"
    src = [
        f"/* {spec['algo']} policy of {spec['env_id']}: generated by python -m spine_gym.agents.export,",
        "   do not edit. */",
        f'#include "{stem}.h"',
    ]
    if "tanh" in spec["network"]["activations"] or spec["network"]["output"] == "squash":
        src.append("#include <math.h> /* tanhf: link with -lm */")
    src += ["", _array("OBS_MEAN", arrays["obs_mean"]), _array("OBS_STD", arrays["obs_std"])]
    if np.isfinite(arrays["clip_obs"]):
        src.append(f"static const float CLIP_OBS = {_f(arrays['clip_obs'])};\n")
    for k in range(len(spec["network"]["activations"])):
        src += [_array(f"W{k}", arrays[f"W{k}"]), _array(f"B{k}", arrays[f"b{k}"])]
    src += [_array("ACT_LOW", arrays["action_low"]), _array("ACT_HIGH", arrays["action_high"])]
    src += [
        "/* y = W x + b, W row-major (n_out, n_in) */",
        "static void dense(const float *w, const float *bias, int n_out, int n_in, const float *x, float *y)",
        "{",
        "    int i, j;",
        "    for (j = 0; j < n_out; j++) {",
        "        const float *row = w + j * n_in;",
        "        float s = 0.0f;",
        "        for (i = 0; i < n_in; i++) s += row[i] * x[i];",
        "        y[j] = s + bias[j];",
        "    }",
        "}",
        "",
    ]
    src += _act_function(arrays, spec)
    if spec["features"]:
        src += _step_function(spec)
    return _header(spec, guard), "\n".join(src)


def write_c(arrays: dict, spec: dict, out: str | Path, stem: str = "policy") -> tuple[Path, Path]:
    """Write ``<stem>.h`` and ``<stem>.c`` into the folder ``out``."""
    out = Path(out)
    header, source = c_sources(arrays, spec, stem)
    h, c = out / f"{stem}.h", out / f"{stem}.c"
    h.write_text(header)
    c.write_text(source)
    return h, c


#: a program around policy.c for tests and timings:
#: ``driver act|step IN OUT [REPEATS]`` reads float32 rows from IN (``POLICY_N_INPUT`` floats for
#: ``act``, ``POLICY_N_OBS`` for ``step``, one episode from the first row), writes the actions as
#: float32 rows to OUT and, with REPEATS > 0, then times REPEATS passes over the rows and prints
#: the wall and CPU nanoseconds per call.
DRIVER_SOURCE = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "policy.h"

static float *read_rows(const char *path, int width, long *n)
{
    FILE *f = fopen(path, "rb");
    long bytes;
    float *buf;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    bytes = ftell(f);
    fseek(f, 0, SEEK_SET);
    *n = bytes / (long)(sizeof(float) * width);
    buf = malloc(bytes > 0 ? (size_t)bytes : 1);
    if (fread(buf, sizeof(float) * width, (size_t)*n, f) != (size_t)*n) { fclose(f); free(buf); return NULL; }
    fclose(f);
    return buf;
}

static void run(int step, const float *in, int width, long n, float *out)
{
    long r;
#ifdef POLICY_HAS_STATE
    policy_state_t s;
    policy_reset(&s);
#endif
    for (r = 0; r < n; r++) {
        if (step) {
#ifdef POLICY_HAS_STATE
            policy_step(&s, in + r * width, out + r * POLICY_N_ACT);
#else
            policy_act(in + r * width, out + r * POLICY_N_ACT);
#endif
        } else {
            policy_act(in + r * width, out + r * POLICY_N_ACT);
        }
    }
}

int main(int argc, char **argv)
{
    int step, width;
    long n, rep, repeats;
    float *in, *out;
    FILE *f;
    if (argc < 4) { fprintf(stderr, "usage: %s act|step IN OUT [REPEATS]\n", argv[0]); return 2; }
    step = strcmp(argv[1], "step") == 0;
    width = step ? POLICY_N_OBS : POLICY_N_INPUT;
    in = read_rows(argv[2], width, &n);
    if (!in) { fprintf(stderr, "cannot read %s\n", argv[2]); return 1; }
    out = malloc(sizeof(float) * POLICY_N_ACT * (size_t)(n > 0 ? n : 1));
    run(step, in, width, n, out);
    f = fopen(argv[3], "wb");
    if (!f || fwrite(out, sizeof(float) * POLICY_N_ACT, (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "cannot write %s\n", argv[3]);
        return 1;
    }
    fclose(f);
    repeats = argc > 4 ? atol(argv[4]) : 0;
    if (repeats > 0 && n > 0) {
        struct timespec t0, t1;
        clock_t c0, c1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        c0 = clock();
        for (rep = 0; rep < repeats; rep++) run(step, in, width, n, out);
        c1 = clock();
        clock_gettime(CLOCK_MONOTONIC, &t1);
        printf("%.3f %.3f\n",
               ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / (double)(repeats * n),
               (c1 - c0) * 1e9 / CLOCKS_PER_SEC / (double)(repeats * n));
    }
    free(in);
    free(out);
    return 0;
}
"""


def compile_driver(bundle: str | Path, workdir: str | Path, cc: str = "cc") -> Path:
    """Compile ``bundle``'s ``policy.c`` with :data:`DRIVER_SOURCE` into ``workdir/driver``
    (``cc -std=c99 -O2 -Wall -Wextra -Werror``, ``-lm``); returns the program's path."""
    bundle, workdir = Path(bundle), Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "driver.c").write_text(DRIVER_SOURCE)
    exe = workdir / "driver"
    cmd = [
        cc,
        "-std=c99",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Werror",
        "-pedantic",
        f"-I{bundle}",
        str(bundle / "policy.c"),
        str(workdir / "driver.c"),
        "-o",
        str(exe),
        "-lm",
    ]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe
