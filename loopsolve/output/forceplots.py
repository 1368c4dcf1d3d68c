"""Pictures of a force analysis: driving torque against the input, joint-force and shaking-force polar plots.

matplotlib is imported lazily (the ``plot`` extra), through :mod:`loopsolve.output.plotting`'s helpers.
Each function returns the matplotlib ``Figure`` and writes it when ``output`` is given.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .plotting import new_figure, save_figure

__all__ = ["plot_drive", "plot_joint_forces", "plot_shaking", "plot_forces"]


def _input_axis(fs):
    ck = fs.sweep.compiled
    inp = ck.inputs[0]
    x = np.asarray(fs.sweep[inp], dtype=float)
    unit = fs.sweep.units()[inp]
    return x, f"{inp} [{unit}]"


def _need_rows(fs, what: str) -> None:
    if len(fs) < 2:
        raise ModelError(f"a {what} plot needs a sweep (forces(mech, start, stop, step)), not one input value")


def plot_drive(fs, *, output=None, ax=None, flywheel=None):
    """Driving torque (or force) against the input, with its mean over the sweep.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "engine_slider_crank.toml")
    >>> fig = ls.forces(mech, 0, 360, 10).plot_torque()
    >>> fig.axes[0].get_ylabel()
    'input_torque [N*m]'
    """
    _need_rows(fs, "driving-torque")
    x, xlabel = _input_axis(fs)
    fig = ax.figure if ax is not None else new_figure((7.0, 3.6))
    ax = ax if ax is not None else fig.add_subplot()
    unit = "N*m" if fs.drive_name == "input_torque" else "N"
    ax.plot(x, fs.drive, lw=1.6, label=fs.drive_name)
    area = float(np.sum(0.5 * (fs.drive[1:] + fs.drive[:-1]) * np.diff(x)))
    mean = area / (x[-1] - x[0]) if x[-1] != x[0] else float(np.mean(fs.drive))
    ax.axhline(mean, color="0.4", lw=1, ls="--", label=f"mean {mean:.4g} {unit}")
    ax.axhline(0, color="0.75", lw=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"{fs.drive_name} [{unit}]")
    ax.set_title(f"{fs.mechanism.name}: driving {'torque' if unit == 'N*m' else 'force'}"
                 + (f" (flywheel {flywheel.inertia:.3g} kg*m^2 for C_s = {flywheel.cs:g})" if flywheel else ""))
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    if output is not None:
        save_figure(fig, output)
    return fig


def _polar(ax, f, title):
    fx, fy = f[:, 0], f[:, 1]
    ax.plot(fx, fy, lw=1.3)
    ax.plot([0], [0], "k+", ms=8)
    if len(fx):
        ax.plot(fx[:1], fy[:1], "o", ms=4, color="C3", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("F_x [N]")
    ax.set_ylabel("F_y [N]")
    ax.set_title(title, fontsize="medium")
    ax.grid(True, alpha=0.3)


def plot_joint_forces(fs, *, joints=None, output=None):
    """Polar plots (F_y against F_x over the sweep) of the joint forces, one panel per joint.

    Examples
    --------
    >>> mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    >>> fig = ls.forces(mech, 0, 360, 10).plot_joint_forces()
    >>> len(fig.axes)
    4
    """
    _need_rows(fs, "joint-force")
    names = list(fs.joint_forces) if joints is None else [j if j.startswith("F_") else f"F_{j}" for j in joints]
    for n in names:
        if n not in fs.joint_forces:
            raise ModelError(f"no joint force {n!r}; the joints are {', '.join(fs.joint_forces)}")
    cols = min(3, len(names))
    rows = -(-len(names) // cols)
    fig = new_figure((3.4 * cols, 3.3 * rows))
    for i, n in enumerate(names):
        _polar(fig.add_subplot(rows, cols, i + 1), fs.joint_forces[n], n)
    fig.suptitle(f"{fs.mechanism.name}: joint forces (on the first body, from the other)")
    if output is not None:
        save_figure(fig, output)
    return fig


def plot_shaking(fs, *, output=None, ax=None):
    """Polar plot of the shaking force (the force of the mechanism on its frame) over the sweep."""
    _need_rows(fs, "shaking-force")
    fig = ax.figure if ax is not None else new_figure((4.4, 4.2))
    ax = ax if ax is not None else fig.add_subplot()
    _polar(ax, fs.shaking_force, f"{fs.mechanism.name}: shaking force")
    if output is not None:
        save_figure(fig, output)
    return fig


def plot_forces(fs, *, output=None, flywheel=None):
    """One figure: driving torque (top), shaking force and the joint forces (polar) below; one input: torque bar."""
    if len(fs) < 2:
        raise ModelError("--plot needs a sweep (--from, --to, --step)")
    names = list(fs.joint_forces)
    cols = max(2, min(4, len(names) + 1))
    rows = 1 + -(-(len(names) + 1) // cols)
    fig = new_figure((3.2 * cols, 3.0 * rows))
    gs = fig.add_gridspec(rows, cols)
    plot_drive(fs, ax=fig.add_subplot(gs[0, :]), flywheel=flywheel)
    panels = [("shaking force", fs.shaking_force)] + [(n, fs.joint_forces[n]) for n in names]
    for i, (title, f) in enumerate(panels):
        _polar(fig.add_subplot(gs[1 + i // cols, i % cols]), f, title)
    if output is not None:
        save_figure(fig, output)
    return fig
