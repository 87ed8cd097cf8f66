"""The numbers the C sources and the Python side share are the same on both sides: parsed from the C headers,
compared with the Python constants.  The binary formats' numbers (sizes, offsets, versions, kinds, flags, named
columns) have one home, harness/fmu/layout.py, from which fmu_src/rom_layout.h is generated (tests/test_fmu_layout.py
checks it is current); here the hand-written rest (doStep's rounding rule, the work bound, the full SPH's flag bits)
and the names the rest of sphrom reads them by.  The value references have one home too, harness/fmu/variables.py,
from which fmu_src/fmu_variables.h is generated (tests/test_variables.py)."""

import re
from pathlib import Path

import sphrom.defaults as defaults
import sphrom.fmu.kinds as kinds
import sphrom.fmu.run.core as core
import sphrom.fmu.training.envelope as envelope
import sphrom.fmu.run.driver as fmi
import sphrom.fmu.check.python_cosim as python_cosim
import sphrom.fmu.resources as resources
import sphrom.fmu.layout as layout
import sphrom.rom.bounds as bounds
import sphrom.fmu.run.sph_c as sph_c
import sphrom.sph.loops as sph_loops
import sphrom.sph.solver as solver

ROOT = Path(__file__).parents[1]
_DEFINE = re.compile(r'^#define\s+(\w+)\s+("[^"]*"|[-+0-9.eE]+u?)\s*(?:/\*.*)?$', re.M)


def header_constants(name):
    """{NAME: value} of the ``#define NAME literal`` lines of fmu_src/<name> (numbers and strings)."""
    out = {}
    for key, text in _DEFINE.findall((ROOT / "fmu_src" / name).read_text()):
        if text.startswith('"'):
            out[key] = text[1:-1]
        else:
            text = text.rstrip("u")
            out[key] = float(text) if any(c in text for c in ".eE") else int(text)
    return out


def test_constants_shared_by_c_and_python():
    rom, sph = {**header_constants("rom.h"), **header_constants("rom_layout.h")}, header_constants("sph.h")
    shared = {
        # resources/model.bin (generated from the layout: the names sphrom reads them by)
        "ROM_RESOURCE_MAGIC": resources.MAGIC.decode(),
        "ROM_FORMAT_VERSION": resources.FORMAT_VERSION,
        "ROM_HEADER_SIZE": resources.HEADER_SIZE,
        "ROM_TOKEN_SIZE": resources.TOKEN_SIZE,
        "ROM_MODEL_FROZEN": resources.MODEL_FROZEN,
        "ROM_MODEL_EXACT_LINEAR": resources.MODEL_EXACT_LINEAR,
        "ROM_INTEGRATOR_EULER": resources.INTEGRATORS["euler"],
        "ROM_INTEGRATOR_SYMPLECTIC": resources.INTEGRATORS["symplectic"],
        "ROM_FLAG_DAMPING": resources.FLAG_DAMPING,
        "ROM_FLAG_INPUT": resources.FLAG_INPUT,
        "ROM_FLAG_SCHUR": resources.FLAG_SCHUR,
        "ROM_FLAG_OUTPUT_ROWS": resources.FLAG_OUTPUT_ROWS,
        "ROM_LINEAR_EXACT_POD": resources.LINEAR_EXACT_POD,
        "ROM_LINEAR_BALANCED": resources.LINEAR_BALANCED,
        "ROM_MAX_MODES": resources.MAX_MODES,
        "ROM_MAX_PROBES": resources.MAX_PROBES,
        "ROM_SECTION_TAG_SIZE": resources.SECTION_TAG_SIZE,
        "ROM_MAX_SECTIONS": resources.MAX_SECTIONS,
        "ROM_MAX_SECTION_VALUES": resources.MAX_SECTION_VALUES,
        "ROM_MAX_PORTS": resources.MAX_PORTS,
        # the training envelope (harness/fmu/training/envelope.py, fmu_src/rom_envelope.c)
        "ROM_ENVELOPE_COLUMNS": envelope.N_SCALARS,
        "ROM_ENVELOPE_CHECK_COORDINATES": envelope.CHECK_COORDINATES,
        "ROM_ENVELOPE_CHECK_FORCE": envelope.CHECK_FORCE,
        "ROM_ENVELOPE_CHECK_STRAIN": envelope.CHECK_STRAIN,
        "ROM_ENVELOPE_CHECK_FAILURE": envelope.CHECK_FAILURE,
        # the certified error bounds' scalars (harness/rom/bounds.py writes SHSCAL in the layout's column order)
        "ROM_SHSCAL_COLUMNS": bounds.N_SCALARS,
        # the serialized FMU state and the core's messages
        "ROM_STATE_HEADER_SIZE": fmi.STATE_HEADER_SIZE,
        "ROM_MESSAGE_SIZE": core.MESSAGE_SIZE,
        # doStep: h/dt within this of a whole number is that many steps; remainders below this x dt are dropped
        "ROM_STEP_ROUNDING": python_cosim.STEP_ROUNDING,
        "ROM_SHORT_STEP_MIN": python_cosim.SHORT_STEP_MIN,
        "ROM_DT_MIN": python_cosim.DT_MIN,
        "ROM_DT_FLOOR_RATIO": python_cosim.DT_FLOOR_RATIO,
        "ROM_MAX_WORK_PER_CALL": python_cosim.MAX_WORK_PER_CALL,
        "ROM_STEP_OVERHEAD": python_cosim.STEP_OVERHEAD,
        # doStep's rules on the time (fmu_src/rom.c check_step, rom_internal.h rom_same_step; sphrom.fmu.kinds)
        "ROM_TIME_ULPS": kinds.TIME_ULPS,
        "ROM_TIME_STEP_TOLERANCE": kinds.TIME_STEP_TOLERANCE,
        "ROM_SAME_STEP": kinds.SAME_STEP,
        # |initial_state_scale| at most (the variable table's min and max, sphrom cosim's range)
        "ROM_MAX_INITIAL_STATE_SCALE": defaults.MAX_INITIAL_STATE_SCALE,
    }
    assert {name: rom.get(name) for name in shared} == shared
    # the value references are not here: fmu_src/fmu_variables.h is generated from harness/fmu/variables.py
    # (tests/test_variables.py)
    assert not any(name.startswith("ROM_VR_") for name in rom)
    # the header sizes are what the layouts add up to: 8 magic + 6 uint32 + 2 float64; 8 magic + 6 uint32 + token
    # + uint64 + 2 float64; the frozen kind's own header 4 uint32 + 1 float64
    assert rom["ROM_HEADER_SIZE"] == 8 + 6 * 4 + 2 * 8
    assert rom["ROM_STATE_HEADER_SIZE"] == 8 + 6 * 4 + rom["ROM_TOKEN_SIZE"] + 8 + 2 * 8
    assert rom["ROM_FROZEN_HEAD_SIZE"] == 4 * 4 + 8
    # no format number is spelled by hand in rom.h: it includes the generated header
    assert not {name for name in header_constants("rom.h") if name in header_constants("rom_layout.h")}
    # the C full SPH's flag bits and methods (fmu_src/sph.h) are the compiled loops'
    sph_shared = {"SPH_DAMPING": sph_loops.DAMPING, "SPH_FORCE": sph_loops.FORCE, "SPH_UNIFORM_C": sph_loops.UNIFORM_C,
                  "SPH_UNIFORM_RHO0": sph_loops.UNIFORM_RHO0, "SPH_UNIFORM_D": sph_loops.UNIFORM_D,
                  "SPH_UNIFORM_PROFILE": sph_loops.UNIFORM_PROFILE, "SPH_STENCIL": sph_loops.STENCIL,
                  "SPH_METHOD_EULER": sph_c.METHODS["euler"], "SPH_METHOD_SYMPLECTIC": sph_c.METHODS["symplectic"]}
    assert {name: sph.get(name) for name in sph_shared} == sph_shared
    assert sph_c.METHODS == {name: solver.METHODS[name] for name in sph_c.METHODS}


def test_section_tags_shared_by_c_and_python():
    """The tags the C loader accepts (rom_resources.c's SECTION_RULES) are the layout's, which the Python writer may
    write, one rule each (rom_resources.c also checks the count against rom_layout.h's at compile time)."""
    text = (ROOT / "fmu_src" / "rom_resources.c").read_text()
    table = text[text.index("SECTION_RULES[] = {"):]
    table = table[:table.index("};")]
    tags = re.findall(r'\{"([^"]+)",', table)
    assert sorted(tags) == sorted(resources.SECTION_TAGS) == sorted(layout.SECTIONS)
