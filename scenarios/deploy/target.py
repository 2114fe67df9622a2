"""The replay on an emulated Cortex-M4F: cross-compiled, run on QEMU's mps2-an386.

:func:`run_target` builds the exported feature window, estimator and controller with
``arm-none-eabi-gcc -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard`` (newlib's
libgcc; a start-up and linker script of griploop's own, semihosting for output),
embeds a replay (the recording's int8 frames and the observations of the host
check), runs it under ``qemu-system-arm -M mps2-an386 -icount shift=7`` and compares
every output with the host build's. Sizes come from ``arm-none-eabi-size`` on the
exported objects (flash: text + data; RAM: data + bss + the state structs).

Instruction counts: under ``-icount shift=S`` QEMU advances its virtual clock by
``2^S`` ns per guest instruction, and the SysTick counts the 25 MHz processor clock of
that virtual time, so ``instructions = ticks * 40 / 2^S``; each call is timed by
reading SysTick around it, less the cost of the reading itself. QEMU counts
instructions, not cycles: a Cortex-M4 takes 1 cycle for most, 2-3 for loads and
multiply-accumulates into memory, 14 for a float division or square root, and more
while its flash waits; the times stated at :data:`CLOCK_HZ` are instructions / clock.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from controllers.base import Observation
from scenarios.deploy.build import C_FLAGS, CompilerMissingError, run_compiler
from scenarios.deploy.check import DecoderCheck, EstimatorReplay, int8_frames
from sim.c_source import c_table, render
from sim.errors import GriploopError
from sim.recording import Recording

CPU_FLAGS = ("-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard")
ICOUNT_SHIFT = 7
#: The clock the instruction counts are converted to time at, Hz (a typical Cortex-M4F).
CLOCK_HZ = 80e6
TARGET_INSTALL = "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"


class TargetToolsMissingError(CompilerMissingError):
    """The cross compiler or the emulator is not installed; says what to install."""


def target_tools() -> dict[str, str]:
    """Paths of ``arm-none-eabi-gcc``, ``arm-none-eabi-size`` and ``qemu-system-arm``.

    Raises
    ------
    TargetToolsMissingError
    """
    names = ("arm-none-eabi-gcc", "arm-none-eabi-size", "qemu-system-arm")
    found = {n: shutil.which(n) for n in names}
    missing = [n for n, p in found.items() if p is None]
    if missing:
        raise TargetToolsMissingError(f"no {', '.join(missing)} for the Cortex-M4 target: "
                                      f"{TARGET_INSTALL}")
    return {n: str(p) for n, p in found.items()}


def _observation_tables(observations: Sequence[Observation]) -> tuple[str, str]:
    real = np.array([(o.reference_n, o.grip_force_n, o.finger_velocity, o.slip_speed_m_s)
                     for o in observations], dtype=float).reshape(-1, 4)
    flags = np.array([(o.thumb_contact, o.finger_contact) for o in observations],
                     dtype=int).reshape(-1, 2)
    return (c_table("gl_obs_real", real, per_line=4),
            c_table("gl_obs_flags", flags, ctype="uint8_t", per_line=16))


def _write_firmware(export: Any, frames: np.ndarray, force_prev: np.ndarray,
                    observations: Sequence[Observation], folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    obs_real, obs_flags = _observation_tables(observations) if observations else ("", "")
    texts = {
        "target_startup.c": render("scenarios.deploy", "target_startup.c.j2"),
        "target_main.c": render(
            "scenarios.deploy", "target_main.c.j2", n_frames=int(frames.shape[0]),
            n_obs=len(observations),
            frames=c_table("gl_frames", frames, ctype="int8_t", per_line=16),
            force_prev=c_table("gl_force_prev", force_prev, per_line=4),
            obs_real=obs_real, obs_flags=obs_flags, decoder=export.decoder is not None),
        "target.ld": render("scenarios.deploy", "target.ld.j2"),
    }
    for name, text in texts.items():
        (folder / name).write_text(text, encoding="utf-8")
    return [folder / "target_startup.c", folder / "target_main.c"]


def _parse(stdout: str) -> tuple[np.ndarray, list[int]]:
    lines = stdout.split()
    if "outputs" not in lines or "ticks" not in lines or "end" not in lines:
        raise GriploopError(f"target run: expected the replay's output, found "
                            f"{stdout[-200:]!r}")
    a, b = lines.index("outputs"), lines.index("ticks")
    values = np.array([int(h, 16) for h in lines[a + 1:b]], dtype=np.uint32).view(np.float32)
    return values, [int(h, 16) for h in lines[b + 1:lines.index("end")]]


def _sizes(tools: dict[str, str], objects: Sequence[Path]) -> dict[str, dict[str, int]]:
    proc = subprocess.run([tools["arm-none-eabi-size"], *map(str, objects)],
                          capture_output=True, text=True, check=True)
    out = {}
    for row in proc.stdout.splitlines()[1:]:
        text, data, bss, *_rest, name = row.split()
        out[Path(name).stem] = {"text": int(text), "data": int(data), "bss": int(bss)}
    return out


def run_target(export: Any, recording: Recording, replay: EstimatorReplay,
               observations: Sequence[Observation], *, c_commands: np.ndarray | None = None,
               c_reference: np.ndarray | None = None,
               build_dir: Path | None = None,
               decoded: DecoderCheck | None = None) -> dict[str, Any]:
    """Cross-compile the export, run the replay on QEMU, compare with the host build.

    Parameters
    ----------
    export : scenarios.deploy.writer.CExport
    recording : Recording
        The replayed recording (its int8 frames are embedded).
    replay : EstimatorReplay
        The host build's replay of the same recording (features, estimates).
    observations : sequence of Observation
        The controller's input sequence (may be empty: no controller replay).
    c_commands : ndarray, optional
        The host build's commands for ``observations``.
    c_reference : ndarray, optional
        The host build's hand reference of each window
        (:func:`scenarios.deploy.check.replay_reference`); compared when given.
    build_dir : Path, optional
        Default ``export.out_dir / "target"``.
    decoded : scenarios.deploy.check.DecoderCheck, optional
        The host build's decoder replay and shaping (an export with a decoder): every
        window's MAV, close and open levels, label and command bounds are compared too,
        and the decoder's instructions (its window's pushes and its step) counted.

    Returns
    -------
    dict
        ``flash_bytes``, ``ram_bytes``, ``instructions_per_update`` (features: per
        feature window, the pushes of its frames included; estimator: per window;
        controller: per control step; with a decoder, ``decoder``: its window's pushes and
        its step per window, and ``features_estimator_decoder``: the three together),
        ``matches_host`` (every output bit-identical to
        the host build's), and the details behind them.

    Raises
    ------
    TargetToolsMissingError, scenarios.deploy.build.BuildError
    """
    tools = target_tools()
    folder = Path(build_dir or export.out_dir / "target")
    frames = int8_frames(recording)
    uses_force = bool(export.estimator.summary["uses_force"])
    force_prev = np.zeros(max(replay.windows, 1))
    if uses_force:
        from estimation.features import align_to_windows

        y = align_to_windows(recording.force_n, recording.fs_hz, window_ms=export.window.window_ms,
                             step_ms=export.window.step_ms)
        force_prev[1:replay.windows] = y[:replay.windows - 1]
    obs = list(observations) if export.controller is not None else []
    sources = _write_firmware(export, frames, force_prev, obs, folder)
    flags = [*C_FLAGS, *CPU_FLAGS, f"-I{export.out_dir}"]
    parts = [p for p in export.sources if p.name != "griploop_runtime.c"]
    objects = []
    for src in parts:
        obj = folder / (src.stem + ".o")
        run_compiler([tools["arm-none-eabi-gcc"], *flags, "-c", str(src), "-o", str(obj)],
                     "arm-none-eabi-gcc")
        objects.append(obj)
    elf = folder / "replay.elf"
    run_compiler([tools["arm-none-eabi-gcc"], *flags, "-nostartfiles", "-T",
                  str(folder / "target.ld"), *map(str, sources), *map(str, objects), "-o",
                  str(elf), "-lm", "-lc", "-lgcc"], "arm-none-eabi-gcc (link)")
    proc = subprocess.run([tools["qemu-system-arm"], "-M", "mps2-an386", "-display", "none",
                           "-monitor", "none", "-serial", "none", "-semihosting",
                           "-icount", f"shift={ICOUNT_SHIFT}", "-kernel", str(elf)],
                          capture_output=True, text=True, timeout=600, check=False)
    values, counts = _parse(proc.stderr)  # QEMU writes semihosting output to stderr
    result = _summarize(export, replay, obs, (c_commands, c_reference, decoded), values, counts,
                        _sizes(tools, objects))
    return result


def _summarize(export: Any, replay: EstimatorReplay, obs: Sequence[Observation],
               host_outputs: tuple[np.ndarray | None, np.ndarray | None, DecoderCheck | None],
               values: np.ndarray, counts: list[int],
               sizes: dict[str, dict[str, int]]) -> dict[str, Any]:
    c_commands, c_reference, decoded = host_outputs
    nf = export.window.n_features
    n_win = replay.windows
    n_ch = export.window.n_armband_channels
    width = nf + 2 + (n_ch + 5 if decoded is not None else 0)
    per_window = values[:n_win * width].reshape(n_win, width)
    commands = values[n_win * width:]
    host = [replay.features_c.astype(np.float32), replay.estimate_c_n.astype(np.float32)]
    target = [per_window[:, :nf], per_window[:, nf]]
    if c_reference is not None:
        host.append(np.asarray(c_reference, dtype=np.float32))
        target.append(per_window[:, nf + 1])
    if decoded is not None:
        d, s = decoded.replay, decoded.shaping
        host += [d.mav_c.astype(np.float32), d.levels_c.astype(np.float32),
                 d.labels_c.astype(np.float32), s.range_c.astype(np.float32)]
        at = nf + 2
        target += [per_window[:, at:at + n_ch], per_window[:, at + n_ch:at + n_ch + 2],
                   per_window[:, at + n_ch + 2], per_window[:, at + n_ch + 3:at + n_ch + 5]]
    if obs and c_commands is not None:
        host.append(np.asarray(c_commands, dtype=np.float32))
        target.append(commands)
    same = all(np.array_equal(h.view(np.uint32), t.view(np.uint32))
               for h, t in zip(host, target, strict=True))
    diff = max(float(np.max(np.abs(h.astype(float) - t.astype(float)), initial=0.0))
               for h, t in zip(host, target, strict=True))
    ticks_f, ticks_e, ticks_c, ticks_empty = ((counts[i] << 32) | counts[i + 1]
                                              for i in range(0, 8, 2))
    windows, size_f, size_e, size_c = counts[8:12]
    n_frames = int(replay.samples)
    per_tick = 40.0 / 2 ** ICOUNT_SHIFT  # instructions per SysTick count
    overhead = ticks_empty / max(n_frames, 1)
    ipu_f = (ticks_f - overhead * n_frames) * per_tick / max(windows, 1)
    ipu_e = (ticks_e - overhead * windows) * per_tick / max(windows, 1)
    ipu_c = ((ticks_c - overhead * len(obs)) * per_tick / len(obs)) if obs else None
    ipu = {"features": int(round(ipu_f)), "estimator": int(round(ipu_e)),
           "controller": None if ipu_c is None else int(round(ipu_c))}
    if decoded is not None:
        ticks_d = (counts[12] << 32) | counts[13]
        ipu_d = (ticks_d - overhead * n_frames) * per_tick / max(windows, 1)
        ipu["decoder"] = int(round(ipu_d))
        ipu["features_estimator_decoder"] = int(round(ipu_f + ipu_e + ipu_d))
    flash = sum(s["text"] + s["data"] for s in sizes.values())
    static_ram = sum(s["data"] + s["bss"] for s in sizes.values())
    state = {"features": size_f, "estimator": size_e, "controller": size_c if obs else None}
    ram = static_ram + size_f + size_e + (size_c if export.controller is not None else 0)
    if decoded is not None:
        state["decoder_window"] = counts[14]
        ram += counts[14]
    period = export.window.step_ms / 1e3
    control_dt = export.controller.summary["control_dt_s"] if export.controller else None
    return {
        "flash_bytes": int(flash), "ram_bytes": int(ram),
        "instructions_per_update": ipu,
        "matches_host": bool(same),
        "max_abs_difference_from_host": diff,
        "outputs_compared": int(sum(h.size for h in host)),
        "state_bytes": state, "objects": sizes,
        "clock_hz": CLOCK_HZ,
        "microseconds_per_update_at_clock": {
            "features": ipu_f / CLOCK_HZ * 1e6, "estimator": ipu_e / CLOCK_HZ * 1e6,
            "controller": None if ipu_c is None else ipu_c / CLOCK_HZ * 1e6},
        "controller_instructions_per_window": (None if ipu_c is None else
                                               int(round(ipu_c * period / control_dt))),
        "counting": f"QEMU -icount shift={ICOUNT_SHIFT}: instructions, not cycles",
    }
