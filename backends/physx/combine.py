"""PyBullet's friction and restitution combine rule (the product) on PhysX materials.

PhysX combines two materials' friction as their average unless a material asks for another
rule (``PxMaterial::setFrictionCombineMode``, ``eMULTIPLY`` = 2); SAPIEN 3.0.3 does not expose
that call. Its shared library keeps PhysX's ``NpMaterial`` symbols, so for exactly that build
the call is reached here through ``ctypes``, every step checked before anything is called:

1. SAPIEN's version is 3.0.3 and its ``libsapien.so`` is mapped in this process (Linux);
2. the exported constructor ``sapien::physx::PhysxMaterial::PhysxMaterial(float, float,
   float)`` is where that build has it, which gives the library's load address;
3. the Python object's C++ ``PhysxMaterial`` points to itself through its
   ``enable_shared_from_this`` (so the pointer read is the object), and its ``PxMaterial``'s
   virtual table is that build's ``NpMaterial`` table, whose slots 20 and 22 are
   ``setFrictionCombineMode`` and ``setRestitutionCombineMode``;
4. after the calls, ``getFrictionCombineMode`` reads back ``eMULTIPLY``.

Where any check fails, nothing is called and materials keep PhysX's average (the manifest says
which).
"""

from __future__ import annotations

import ctypes
import sys
from typing import Any

import sapien

__all__ = ["set_product_combine", "product_combine_available"]

_VERSION = "3.0.3"
_CTOR = "_ZN6sapien5physx13PhysxMaterialC1Efff"
# offsets in libsapien.so of SAPIEN 3.0.3's wheel (nm -C libsapien.so)
_CTOR_OFFSET = 0xDFCD0
_NP_MATERIAL_VTABLE = 0x6E6F50 + 16  # the address point: after offset-to-top and type info
_SET_FRICTION_COMBINE = 0x3020F0
_GET_FRICTION_COMBINE = 0x302110
_SET_RESTITUTION_COMBINE = 0x302120
_SLOT_SET_FRICTION, _SLOT_SET_RESTITUTION = 20, 22
MULTIPLY = 2  # PxCombineMode::eMULTIPLY

_state: dict[str, Any] = {}


def _library_base() -> int | None:
    if sapien.__version__ != _VERSION or not sys.platform.startswith("linux"):
        return None
    try:
        with open("/proc/self/maps") as maps:
            paths = [line.split()[-1] for line in maps if line.rstrip().endswith("libsapien.so")]
        if not paths:
            return None
        lib = ctypes.CDLL(paths[0])
        ctor = ctypes.cast(getattr(lib, _CTOR), ctypes.c_void_p).value
    except (OSError, AttributeError, IndexError):
        return None
    if ctor is None:
        return None
    return ctor - _CTOR_OFFSET


def _functions() -> tuple[int, Any, Any, Any] | None:
    if "functions" not in _state:
        base = _library_base()
        if base is None:
            _state["functions"] = None
        else:
            setter = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int)
            getter = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p)
            _state["functions"] = (
                base,
                setter(base + _SET_FRICTION_COMBINE),
                setter(base + _SET_RESTITUTION_COMBINE),
                getter(base + _GET_FRICTION_COMBINE),
            )
    functions: tuple[int, Any, Any, Any] | None = _state["functions"]
    return functions


def _px_material(material: Any, base: int) -> int | None:
    """The ``PxMaterial*`` of a SAPIEN ``PhysxMaterial``, or None where a check fails."""
    word = ctypes.c_void_p
    values = word.from_address(id(material) + 16).value  # pybind11: the instance's values
    if not values:
        return None
    cpp = word.from_address(values).value
    if not cpp or word.from_address(cpp).value != cpp:  # enable_shared_from_this's self
        return None
    px = word.from_address(cpp + 32).value  # after the weak self and the engine's shared_ptr
    if not px or word.from_address(px).value != base + _NP_MATERIAL_VTABLE:
        return None
    table = base + _NP_MATERIAL_VTABLE
    if word.from_address(table + 8 * _SLOT_SET_FRICTION).value != base + _SET_FRICTION_COMBINE:
        return None
    restitution = word.from_address(table + 8 * _SLOT_SET_RESTITUTION).value
    if restitution != base + _SET_RESTITUTION_COMBINE:
        return None
    return px


def set_product_combine(material: Any) -> bool:
    """Give ``material`` PyBullet's product rule for friction and restitution.

    Args:
        material: A ``sapien.physx.PhysxMaterial``.

    Returns:
        Whether the rule took; False (and nothing done) where this SAPIEN build cannot be reached
        safely.
    """
    functions = _functions()
    if functions is None:
        return False
    base, set_friction, set_restitution, get_friction = functions
    px = _px_material(material, base)
    if px is None:
        return False
    set_friction(px, MULTIPLY)
    set_restitution(px, MULTIPLY)
    return bool(get_friction(px) == MULTIPLY)


def product_combine_available() -> bool:
    """Whether :func:`set_product_combine` works in this process (tried once, on a new material).

    Returns:
        True where it works.
    """
    if "available" not in _state:
        _state["available"] = set_product_combine(sapien.physx.PhysxMaterial(0.5, 0.5, 0.0))
    return bool(_state["available"])
