"""Load a wing's modules when a name from them is first used (PEP 562).

``import nh_operators`` then costs what numpy costs, not what torch, DeepXDE and numba
cost, and a classical solve never loads torch. Every package ``__init__`` declares its
public names and the module that defines each; :func:`attach` turns that table into the
module's ``__getattr__``, ``__dir__`` and ``__all__``. A name is imported on first access
and then cached in the package's namespace, so later lookups are plain attribute reads.
"""

import importlib

__all__ = ["attach"]


def attach(package, exports):
    """The ``(__getattr__, __dir__, __all__)`` of a package whose names load lazily.

    Args:
        package: the package's ``__name__``.
        exports: dict module -> list of names it defines, in the order of ``__all__``.
            A module is a sibling in the same package (``"fixed_step"``) or, for the
            top-level package, a wing (``"solvers"``), which then supplies the name.

    Returns:
        (``__getattr__``, ``__dir__``, ``__all__``) to assign at module level.

    Raises:
        ValueError: for a name listed twice, or a dotted module (a wing loads only its
            own modules).

    Example:
        >>> getattr_, dir_, all_ = attach("nh_operators.solvers", {"schemes": ["ORDERS"]})
        >>> all_, getattr_("ORDERS")["rk4"]
        (['ORDERS'], 4)
    """
    where = {}
    for module, names in exports.items():
        if "." in module:
            raise ValueError(f"{package}: {module!r} is not a module of this package")
        for name in names:
            if name in where:
                raise ValueError(f"{package}: {name!r} is exported by {where[name]!r} and "
                                 f"{module!r}")
            where[name] = module
    names = list(where)

    def __getattr__(name):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        importlib.import_module(package).__dict__[name] = value  # cache: no second lookup
        return value

    def __dir__():
        return sorted(set(importlib.import_module(package).__dict__) | set(names))

    return __getattr__, __dir__, names
