"""The battery's FMU cases (:mod:`tests.hostile.battery`): mutated resources through the C core, mutated
serialized states and FMI call sequences through fmpy, the round-four cases of the C side (time at any start, the
shadow's sections edited, initial_state_scale, the Error state), each in a child process that is restarted after a
crash or a stall.

Outcomes as in :mod:`tests.hostile.battery`: a refusal with the FMU's message is a clean error; an OK status
with non-finite outputs, or a corrupted file or state accepted, is a silent wrong result; a child that dies in a
case (SIGSEGV, SIGABRT) is a traceback; one that does not answer within 20 s is a hang.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import random
import struct
import subprocess
import sys
import threading
import time
import zlib
from pathlib import Path

from sphrom.fmu import layout

REPO = Path(__file__).resolve().parents[2]


def _recrc(blob: bytes) -> bytes:
    return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]) & 0xFFFFFFFF)


def mutations(blob: bytes, rng, count):
    """(description, bytes): truncations, flipped bytes (checksum left: must be refused), flipped bytes with the
    checksum recomputed, doubles replaced by NaN/inf/0/huge/tiny (checksum recomputed)."""
    out = []
    n = len(blob)
    for _ in range(count):
        how = rng.random()
        b = bytearray(blob)
        if how < 0.15:
            cut = rng.randrange(0, n)
            out.append((f"truncated to {cut}", bytes(b[:cut]), True))
            continue
        if how < 0.35:
            i = rng.randrange(0, n - 4)
            b[i] ^= 1 << rng.randrange(8)
            out.append((f"bit flipped at {i}", bytes(b), True))
            continue
        if how < 0.7:
            for _ in range(rng.choice((1, 1, 2, 8))):
                i = rng.randrange(0, n - 4)
                b[i] = rng.randrange(256)
            out.append(("bytes changed, checksum recomputed", _recrc(bytes(b)), False))
            continue
        i = 8 * rng.randrange(0, (n - 4) // 8)
        value = rng.choice((float("nan"), float("inf"), -float("inf"), 0.0, 1e308, -1e308, 5e-324, 1e-12, 1e12))
        b[i:i + 8] = struct.pack("<d", value)
        out.append((f"double at {i} = {value!r}, checksum recomputed", _recrc(bytes(b)), False))
    return out


def _child_resources(core_path, cases, emit):
    import numpy as np

    from sphrom.fmu.run.core import Core, CoreError
    core = Core(core_path)
    for i, (desc, hexblob, must_refuse) in enumerate(cases):
        emit({"i": i, "start": True})
        blob = bytes.fromhex(hexblob)
        try:
            model = core.load(blob)
        except CoreError as exc:
            emit({"i": i, "outcome": "clean error", "detail": str(exc)[:200]})
            continue
        if must_refuse:
            emit({"i": i, "outcome": "silent wrong result", "detail": "a corrupted file was accepted"})
            model.close()
            continue
        try:
            model.reset(0.0)
            t = 0.0
            for k in range(20):
                model.set_input(0.01 * math.sin(k))
                model.do_step(t, 0.01)
                t += 0.01
            v, rho = model.outputs(1)
            finite = bool(np.all(np.isfinite(v)) and np.all(np.isfinite(rho)))
            bounds = _error_bounds(core, model)
            signed = bool(np.all(bounds >= 0))              # certified bounds: >= 0 (+inf allowed), never NaN
            emit({"i": i, "outcome": "ok" if finite and signed else "silent wrong result",
                  "detail": "" if finite and signed else f"status OK, outputs {v} {rho}, bounds {bounds}"})
        except CoreError as exc:
            emit({"i": i, "outcome": "clean error", "detail": str(exc)[:200]})
        finally:
            model.close()


def _error_bounds(core, model):
    """The certified bounds of v and rho at the first probe of a model the core holds (empty without bounds)."""
    import ctypes

    import numpy as np
    lib = core.lib
    lib.rom_has_bounds.argtypes = [ctypes.c_void_p]
    lib.rom_has_bounds.restype = ctypes.c_int
    if not lib.rom_has_bounds(model.model):
        return np.zeros(0)
    values = []
    for name in ("rom_v_probe_error_bound", "rom_rho_probe_error_bound"):
        fn = getattr(lib, name)
        fn.argtypes = [ctypes.c_void_p, ctypes.c_uint32]
        fn.restype = ctypes.c_double
        values.append(fn(model.state, 0))
    return np.array(values)


def verdict(emit, i, messages, outputs=None, exc=None, done=""):
    """Emit case ``i``'s outcome: OK with ``outputs`` all finite, a silent wrong result when some are not; after
    ``exc`` a clean error when the FMU logged why (``messages``: the FMU's log), else an unclear one."""
    import numpy as np
    if exc is None:
        finite = bool(np.all(np.isfinite(outputs)))
        emit({"i": i, "outcome": "ok" if finite else "silent wrong result",
              "detail": done if finite else "status OK, non-finite outputs"})
        return
    errors = [m for status, _, m in messages if status >= 3]
    emit({"i": i, "outcome": "clean error" if errors else "unclear error",
          "detail": (errors[-1] if errors else f"error without a message ({exc})")[:200]})


def _slave(unzipdir, messages):
    from sphrom.fmu.run.driver import FMU
    return FMU(unzipdir, messages=messages)


def _child_states(unzipdir, base_hex, cases, emit):
    from fmpy.fmi1 import FMICallException
    for i, (desc, hexblob, must_refuse) in enumerate(cases):
        emit({"i": i, "start": True})
        messages = []
        slave = _slave(unzipdir, messages)
        try:
            slave.initialize()
            try:
                state = slave.deserialize(bytes.fromhex(hexblob))
            except (FMICallException, Exception) as exc:
                errors = [m for s, _, m in messages if s >= 3]
                emit({"i": i, "outcome": "clean error" if errors else "unclear error",
                      "detail": (errors[-1] if errors else f"refused without a message ({exc})")[:200]})
                continue
            if must_refuse:
                emit({"i": i, "outcome": "silent wrong result", "detail": "a corrupted state was accepted"})
                continue
            try:
                slave.set_state(state)
                outs = slave.run([0.01] * 5, [0.01] * 5, t0=slave.time())[1:]
                verdict(emit, i, messages, outputs=outs)
            except Exception as exc:
                verdict(emit, i, messages, exc=exc)
        finally:
            with contextlib.suppress(Exception):
                slave.close()


CALLS = ("setup", "enter", "exit", "step", "set_f", "set_f_bad", "get", "terminate", "reset", "get_state",
         "set_state", "set_n_freeze", "set_dt", "set_rate", "set_scale")


def _child_sequences(unzipdir, cases, emit):
    """Random FMI call sequences: an OK status must come with finite outputs; an error with a message."""
    import numpy as np

    from sphrom.fmu.variables import vr
    VR_DT, VR_F, VR_INITIAL_STATE_SCALE, VR_N_FREEZE = (vr(name) for name in ("dt", "f", "initial_state_scale",
                                                                              "n_freeze"))
    for i, (seed, length) in enumerate(cases):
        emit({"i": i, "start": True})
        rng = random.Random(seed)
        messages = []
        slave = _slave(unzipdir, messages)
        fmu, fmi = slave.fmu, slave.fmi
        states, t, bad, unclear = [], 0.0, None, None
        calls = []
        try:
            for _ in range(length):
                call = rng.choice(CALLS)
                calls.append(call)
                before = len([m for m in messages if m[0] >= 3])
                try:
                    if call == "setup":
                        if fmi == 2:
                            fmu.setupExperiment(startTime=rng.choice((0.0, 1.0, -1.0)))
                    elif call == "enter":
                        fmu.enterInitializationMode()
                    elif call == "exit":
                        fmu.exitInitializationMode()
                    elif call == "step":
                        h = rng.choice((0.01, 0.01, 0.003, 0.0, -0.01, float("nan"), float("inf"), 1e-9, 5.0))
                        t0 = rng.choice((t, t, 0.0, t + 1.0, float("nan")))
                        slave.do_step(t0, h)
                        t = t0 + h
                    elif call in ("set_f", "set_f_bad"):
                        value = 0.01 if call == "set_f" else rng.choice((float("nan"), float("inf"), 1e308, -1e308))
                        slave.set_real([VR_F], [value])
                    elif call == "get":
                        values = slave.output_values()
                        if not np.all(np.isfinite(values)):
                            bad = f"OK status, non-finite outputs after {calls}"
                    elif call == "terminate":
                        fmu.terminate()
                    elif call == "reset":
                        fmu.reset()
                        t = 0.0
                    elif call == "get_state":
                        states.append(slave.get_state())
                    elif call == "set_state" and states:
                        slave.set_state(rng.choice(states))
                    elif call == "set_n_freeze":
                        value = rng.choice((1, 10, 0, -5, 2**31 - 1))
                        (fmu.setInteger if fmi == 2 else fmu.setInt32)([VR_N_FREEZE], [value])
                    elif call == "set_dt":
                        slave.set_real([VR_DT], [rng.choice((2e-4, 1e-3, 0.0, -1.0, float("nan"), 1e300))])
                    elif call == "set_scale":
                        slave.set_real([VR_INITIAL_STATE_SCALE], [rng.choice((0.0, 1.0, float("nan"), 1e308))])
                    elif call == "set_rate" and fmi == 2:
                        slave.set_input_derivative(rng.choice((0.0, 1.0, float("nan"))))
                except Exception:
                    after = len([m for m in messages if m[0] >= 3])
                    if after == before:
                        unclear = unclear or f"{call} failed without a message after {calls[:-1]}"
            outcome = "silent wrong result" if bad else "unclear error" if unclear else "ok"
            emit({"i": i, "outcome": outcome, "detail": bad or unclear or f"{len(calls)} calls"})
        finally:
            for s in states:
                with contextlib.suppress(Exception):
                    slave.free_state(s)
            with contextlib.suppress(Exception):
                slave.close()


# Byte offset of the internal step dt in resources/model.bin: the frozen kind's header (harness/fmu/layout.py; in a
# serialized state, layout.state_offset)
RESOURCE_DT_AT = layout.resource_offset("frozen", "dt")
# The largest communication step tried and the time one doStep must answer in [s]
STEP_BOUND_CASES = (("dt parameter", 1e-12, 0.01), ("dt parameter", 1e-9, 1.0), ("state dt", 1e-12, 0.01),
                    ("resources dt", 1e-12, 0.01), ("communication step", None, 1e4), ("communication step", None, 1e7))


def step_bound_cases(ws, fmu_names):
    """The work of one doStep: a tiny internal dt (set as the parameter, carried by a state or by a resource file,
    checksums recomputed) or a huge communication step must be answered (done, or refused naming the limit)
    within the child's per-case time (10 s), FMI 2 and 3, frozen and exact."""
    import shutil
    from fmpy import extract, read_model_description
    cases, labels = [], []
    for name in fmu_names:
        unzipdir = str(extract(str(ws[name]), unzipdir=str(ws.root / f"step-{name}")))
        patched = ws.root / f"step-{name}-dt"
        shutil.rmtree(patched, ignore_errors=True)
        shutil.copytree(unzipdir, patched)
        has_dt = any(v.name == "dt" for v in read_model_description(unzipdir).modelVariables)
        if has_dt:                                          # the frozen kind's resources carry dt
            blob = bytearray((patched / "resources" / "model.bin").read_bytes())
            blob[RESOURCE_DT_AT:RESOURCE_DT_AT + 8] = struct.pack("<d", 1e-12)
            (patched / "resources" / "model.bin").write_bytes(_recrc(bytes(blob)))
        for kind, dt, h in STEP_BOUND_CASES:
            if "dt" in kind.split() and not has_dt:         # a linear FMU: no internal step, no dt anywhere
                continue
            cases.append((kind, dt, h, str(patched) if kind == "resources dt" else unzipdir))
            labels.append(f"{name}: {kind}" + (f" dt = {dt:g} s" if dt else "") + f", doStep h = {h:g} s")
    return cases, labels


def _child_step_bound(cases, emit):
    for i, (kind, dt, h, unzipdir) in enumerate(cases):
        emit({"i": i, "start": True})
        messages = []
        try:
            slave = _slave(unzipdir, messages)
        except Exception as exc:
            errors = [m for st, _, m in messages if st >= 3]
            emit({"i": i, "outcome": "clean error" if errors else "unclear error",
                  "detail": (errors[-1] if errors else str(exc))[:200]})
            continue
        try:
            slave.initialize(dt=dt if kind == "dt parameter" else None)
            if kind == "state dt":
                state = slave.get_state()
                blob = bytearray(slave.serialize(state))
                slave.free_state(state)
                at = layout.state_offset(blob, "frozen", "dt")
                blob[at:at + 8] = struct.pack("<d", dt)
                slave.set_state(slave.deserialize(_recrc(bytes(blob))))
            slave.set_input(0.01)
            slave.do_step(slave.time(), h)
            verdict(emit, i, messages, outputs=slave.output_values(), done="done")
        except Exception as exc:
            verdict(emit, i, messages, exc=exc)
        finally:
            with contextlib.suppress(Exception):
                slave.close()


# Round four on the FMU's C side (issue 36): 3 time exact at any start, 8 resources validated for their signs and
# ranges, 11 initial_state_scale bounded and the getters allowed in the Error state.  Each case: (kind, FMU name,
# arguments); run by _child_round_four.
EPOCH = 1.7e9
EPOCH_STEPS = [1e-6, 3.5e-6, 3.5e-6, 3.5e-6] + [0.01] * 10 + [0.01, 0.013] * 5
EDITS = {"negated": -1.0, "x 1e6": 1e6, "x 1e-6": 1e-6}
SHADOW_TAGS = ("SHLAM", "SHB", "SHC", "SHW0", "SHROW", "SHRATE", "SHTAB", "SHTERR", "SHCONT", "SHPROBE",
               "SHSCAL")


def round_four_cases(ws, fmu_names):
    """(cases, labels) of the round-four FMU cases: the epoch start, a communication point ahead, a time that
    overflows or does not advance, initial_state_scale out of range, reading in the Error state, and every section
    of the error bounds' shadow negated or scaled by 1e6 or 1e-6 (checksum recomputed)."""
    import shutil
    from fmpy import extract
    cases, labels = [], []
    for name in fmu_names:
        unzipdir = str(extract(str(ws[name]), unzipdir=str(ws.root / f"round4-{name}")))
        for kind, args, label in (("epoch", [], f"started at {EPOCH:g} s: the outputs of a start at 0"),
                                  ("ahead", [], f"at {EPOCH:g} s a communication point 1 s ahead"),
                                  ("overflow", [1e308, 1e308], "started at 1e308 s, doStep(h = 1e308)"),
                                  ("overflow", [1e308, 0.01], "started at 1e308 s, doStep(h = 0.01)"),
                                  ("overflow", [EPOCH, 1e-8], f"at {EPOCH:g} s, doStep(h = 1e-8)"),
                                  ("scale", [1e308], "initial_state_scale = 1e308"),
                                  ("scale", [-1e4], "initial_state_scale = -1e4"),
                                  ("scale", [1000.0], "initial_state_scale = 1000 (the largest)"),
                                  ("error state", [], "getters and getFMUstate in the Error state")):
            cases.append((kind, unzipdir, args))
            labels.append(f"{name}: {label}")
        blob = (Path(unzipdir) / "resources" / "model.bin").read_bytes()
        for tag in SHADOW_TAGS:
            if tag.encode("ascii").ljust(8, b"\0") not in blob:
                continue                                  # (SHTAB, SHTERR, SHCONT: only with a free response outside)
            for how, factor in EDITS.items():
                folder = ws.root / f"round4-{name}-{tag}-{how.replace(' ', '')}"
                shutil.rmtree(folder, ignore_errors=True)
                shutil.copytree(unzipdir, folder)
                (folder / "resources" / "model.bin").write_bytes(scaled_section(blob, tag, factor))
                cases.append(("section", str(folder), [tag, how]))
                labels.append(f"{name}: section {tag} {how}, checksum recomputed")
    return cases, labels


def scaled_section(blob, tag, factor):
    """``blob`` with section ``tag``'s values times ``factor`` in place, the checksum recomputed."""
    import numpy as np
    at = blob.index(tag.encode("ascii").ljust(8, b"\0"))
    rows, cols = struct.unpack_from("<II", blob, at + 8)
    start = at + layout.SECTION.size
    values = np.frombuffer(blob, "<f8", rows * cols, start) * factor
    return _recrc(blob[:start] + values.astype("<f8").tobytes() + blob[start + 8 * rows * cols:])


def _run_steps(slave, start, steps, f=0.02):
    import numpy as np
    t, rows = start, [slave.get_real([slave.vr[n] for n in slave.outputs])]
    for h in steps:
        slave.do_step(t, h)
        t = t + h
        rows.append(slave.get_real([slave.vr[n] for n in slave.outputs]))
    return np.array(rows)


def _child_round_four(cases, emit):
    import numpy as np
    for i, (kind, unzipdir, args) in enumerate(cases):
        emit({"i": i, "start": True})
        messages = []
        try:
            slave = _slave(unzipdir, messages)
        except Exception as exc:
            verdict(emit, i, messages, exc=exc)
            continue
        try:
            if kind == "epoch":
                slave.initialize(start=0.0, initial_state_scale=1, f=0.02)
                at_zero = _run_steps(slave, 0.0, EPOCH_STEPS)
                slave.fmu.reset()
                slave.initialize(start=EPOCH, initial_state_scale=1, f=0.02)
                later = _run_steps(slave, EPOCH, EPOCH_STEPS)
                worst = float(np.max(np.abs(later - at_zero) / (np.abs(at_zero) + 1e-300)))
                emit({"i": i, "outcome": "ok" if worst <= 1e-12 else "silent wrong result",
                      "detail": f"largest relative difference {worst:.3g}"})
            elif kind in ("ahead", "overflow"):
                start, h = (EPOCH, 0.01) if kind == "ahead" else args
                slave.initialize(start=start, initial_state_scale=1)
                try:
                    slave.do_step(start + (1.0 if kind == "ahead" else 0.0), h)
                except Exception as exc:
                    verdict(emit, i, messages, exc=exc)
                    continue
                emit({"i": i, "outcome": "silent wrong result", "detail": f"accepted with OK, time {slave.time()}"})
            elif kind == "scale":
                try:
                    slave.initialize(initial_state_scale=args[0])
                    slave.do_step(0.0, 0.01)
                except Exception as exc:
                    verdict(emit, i, messages, exc=exc)
                    continue
                ok = abs(args[0]) <= 1000 and np.all(np.isfinite(slave.output_values()))
                emit({"i": i, "outcome": "ok" if ok else "silent wrong result",
                      "detail": "" if ok else f"initial_state_scale {args[0]:g} accepted"})
            elif kind == "error state":
                slave.initialize(initial_state_scale=1, f=0.01)
                slave.do_step(0.0, 0.01)
                good = slave.output_values()
                try:
                    slave.do_step(5.0, 0.01)
                    emit({"i": i, "outcome": "silent wrong result", "detail": "a wrong point accepted"})
                    continue
                except Exception:
                    pass
                same = np.array_equal(slave.output_values(), good)
                state = slave.get_state()
                slave.serialize(state)
                slave.free_state(state)
                try:
                    slave.do_step(0.01, 0.01)
                    emit({"i": i, "outcome": "silent wrong result", "detail": "doStep accepted in the Error state"})
                    continue
                except Exception:
                    pass
                emit({"i": i, "outcome": "ok" if same else "silent wrong result",
                      "detail": "read the last good values, the state; doStep refused" if same else "values changed"})
            else:                                          # section edits: refused at instantiation, or bounds >= 0
                slave.initialize(initial_state_scale=1, f=0.02)
                names = [n for n in slave.outputs if n.endswith("_error_bound")]
                y = slave.simulate(0.01 * np.arange(21), {"f": np.full(21, 0.02)}, outputs=names)
                bad = (~(y >= 0)).sum()
                emit({"i": i, "outcome": "ok" if bad == 0 else "silent wrong result",
                      "detail": "bounds finite or +inf and >= 0" if bad == 0 else f"{bad} bounds negative or NaN "
                                                                                      f"(least {np.nanmin(y):.3g})"})
        except Exception as exc:
            verdict(emit, i, messages, exc=exc)
        finally:
            with contextlib.suppress(Exception):
                slave.close()


def child_main(spec_path):
    spec = json.loads(Path(spec_path).read_text())

    def emit(record):
        sys.stdout.write(json.dumps(record) + "\n")
        sys.stdout.flush()
    kind = spec["kind"]
    if kind == "step bound":
        _child_step_bound(spec["cases"], emit)
    elif kind == "round four":
        _child_round_four(spec["cases"], emit)
    elif kind == "resources":
        _child_resources(spec["core"], spec["cases"], emit)
    elif kind == "states":
        _child_states(spec["unzipdir"], spec["base"], spec["cases"], emit)
    else:
        _child_sequences(spec["unzipdir"], spec["cases"], emit)


def run_children(ws, kind, payload, cases, labels, category, per_case_timeout=20.0):
    """Run ``cases`` in child processes; a case in flight when the child crashes or stalls gets that outcome, and
    a new child goes on from the next case.  Returns (category, kind, label, outcome, detail) per case."""
    results = []
    start = 0
    while start < len(cases):
        spec_file = ws.root / f"child-{kind}.json"
        spec_file.write_text(json.dumps({"kind": kind, **payload, "cases": cases[start:]}))
        proc = subprocess.Popen([sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
                                 "from tests.hostile.fmu_cases import child_main; child_main(sys.argv[2])",
                                 str(REPO), str(spec_file)],
                                cwd=ws.root, env=ws.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        current, done = None, {}
        timer_state = {"last": time.monotonic()}

        def watchdog():
            while proc.poll() is None:
                if time.monotonic() - timer_state["last"] > per_case_timeout:
                    timer_state["hung"] = True
                    proc.kill()
                    return
                time.sleep(0.2)
        threading.Thread(target=watchdog, daemon=True).start()
        for line in proc.stdout:
            timer_state["last"] = time.monotonic()
            try:
                record = json.loads(line)
            except ValueError:
                continue
            if record.get("start"):
                current = record["i"]
            else:
                done[record["i"]] = record
        proc.wait()
        stderr = proc.stderr.read()
        for i in sorted(done):
            results.append((start + i, done[i]["outcome"], done[i]["detail"]))
        if current is not None and current not in done:          # crashed or hung in this case
            if timer_state.get("hung"):
                results.append((start + current, "hang", f"no answer within {per_case_timeout:g} s"))
            else:
                results.append((start + current, "traceback",
                                f"child died (status {proc.returncode}): {stderr.strip().splitlines()[-1:] }"[:300]))
            start = start + current + 1
        elif current is None and proc.returncode != 0:
            raise RuntimeError(f"{kind} child failed to start: {stderr[-2000:]}")
        else:
            break
    return [(category, kind, labels[i], outcome, detail) for i, outcome, detail in sorted(results)]


def fmu_cases(ws, rng, n_resources, n_states, n_sequences):
    import numpy as np
    from fmpy import extract

    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.run.driver import FMU
    os.environ["SPHROM_CACHE"] = ws.env["SPHROM_CACHE"]          # the workspace's build of the binaries
    binaries = ensure_binaries(quiet=True)
    results = []
    for fmu_name in ("fmu2", "exact2"):
        blob = zipfile_read(ws[fmu_name], "resources/model.bin")
        muts = mutations(blob, rng, n_resources // 2)
        results += run_children(ws, "resources", {"core": str(binaries.core)},
                                [(d, b.hex(), r) for d, b, r in muts], [f"{fmu_name}: {d}" for d, _, _ in muts],
                                "resources")
    for fmu_name in ("fmu2", "fmu3", "exact2"):
        unzipdir = str(extract(str(ws[fmu_name]), unzipdir=str(ws.root / f"unzipped-{fmu_name}")))
        with FMU(unzipdir) as slave:
            slave.initialize()
            slave.simulate(0.01 * np.arange(6), {"f": np.full(6, 0.01)}, outputs=[], steps=np.full(5, 0.01))
            state = slave.get_state()
            base = slave.serialize(state)
            slave.free_state(state)
        muts = mutations(base, rng, n_states // 3)
        results += run_children(ws, "states", {"unzipdir": unzipdir, "base": base.hex()},
                                [(d, b.hex(), r) for d, b, r in muts], [f"{fmu_name}: {d}" for d, _, _ in muts],
                                "states")
        seqs = [(rng.randrange(10**9), rng.randrange(3, 25)) for _ in range(n_sequences // 3)]
        results += run_children(ws, "sequences", {"unzipdir": unzipdir}, seqs,
                                [f"{fmu_name}: seed {s}, {n} calls" for s, n in seqs], "call sequences")
    cases, labels = step_bound_cases(ws, ("fmu2", "fmu3", "exact2"))
    results += run_children(ws, "step bound", {}, cases, labels, "step bound", per_case_timeout=10.0)
    cases, labels = round_four_cases(ws, ("fmu2", "fmu3", "exact2"))
    results += run_children(ws, "round four", {}, cases, labels, "round four FMU")
    return results


def zipfile_read(path, name):
    import zipfile
    with zipfile.ZipFile(path) as zf:
        return zf.read(name)
