"""Pinocchio data per thread: the model is shared, the data belongs to whoever computes.

Pinocchio splits a robot into its Model (constant) and a Data (every buffer a kinematics call
writes). One RobotModel serves every thread of a process (concurrent plans, service callbacks, a
servo loop), so no Data lives on it: a computation that keeps its buffers across calls (an IK
solver, a Cartesian step solver, a compiled scene) owns a Data of its own, and a one-off query
(a RobotState's forward kinematics) takes its thread's Data from here.
"""
from __future__ import annotations

import threading
import weakref
from typing import TYPE_CHECKING

import pinocchio as pin

if TYPE_CHECKING:  # pragma: no cover
    from .robot_model import RobotModel

__all__ = ["thread_data", "thread_store"]

_LOCAL = threading.local()


def thread_data(model: "RobotModel") -> pin.Data:
    """The calling thread's Pinocchio data for ``model``: made on first use, dropped with the
    thread or the model. Valid until this thread's next kinematics call on the same model."""
    try:
        last_model, last_data = _LOCAL.last  # the common case: one model per thread
        if last_model() is model:
            return last_data
    except AttributeError:
        pass
    return _lookup(model)


def thread_store(model: "RobotModel") -> dict:
    """The calling thread's dict for ``model``, dropped with the thread or the model: where code
    keeps what it builds once per thread for a model (its Pinocchio data, IK solvers)."""
    local = _LOCAL
    try:
        table = local.table
    except AttributeError:
        table = local.table = weakref.WeakKeyDictionary()
    store = table.get(model)
    if store is None:
        store = table[model] = {}
    return store


def _lookup(model: "RobotModel") -> pin.Data:
    store = thread_store(model)
    data = store.get("pin_data")
    if data is None:
        data = store["pin_data"] = model.pin_model.createData()
    _LOCAL.last = (weakref.ref(model), data)
    return data
