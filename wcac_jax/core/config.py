"""The configurations' shared base: fields declared once with their doc and validation.

Everything in a configuration is static (closed over by the compiled program); what is
swept — the preference vector and the PRNG key — is a traced argument of `train`, never
config. Each update declares its configuration as a `Config` subclass under `@frozen_config`,
one `field(default, doc, check)` per hyperparameter; from those declarations come the
validation (`__post_init__`), `replace`, `to_dict` / `from_dict` and the command line's
flags (`wcac_jax.sweep.cli`). Derived sizes are properties. Invalid values raise `ValueError`
naming the field, the bad value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

# The programs compute in float32: a value finite in float64 but not in float32 (e.g.
# 1e39) would only show up later as a NaN "divergence".
F32_MAX = 3.4028234663852886e38  # numpy.finfo(numpy.float32).max


def finite_f32(value) -> bool:
    """Whether `value` is a number that is finite in float32 (False for inf and NaN)."""
    try:
        return abs(float(value)) <= F32_MAX
    except (TypeError, ValueError):
        return False


# ----------------------------------------------------------------------------- checks
# A check takes `(name, value)`, raises `ValueError` on a bad value and returns the value
# to store (e.g. a list made a tuple).

Check = Callable[[str, Any], Any]


def positive_int(name: str, value):
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return value


def positive(name: str, value):
    """`> 0` and finite in float32."""
    if not value > 0:  # also rejects NaN
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if not finite_f32(value):
        raise ValueError(f"{name} must be finite in float32, got {value!r}")
    return value


def positive_below_f32_max(name: str, value):
    """`positive`, its message naming float32's largest value."""
    if value > 0 and not finite_f32(value):
        raise ValueError(f"{name} must be finite in float32 (< {F32_MAX:.4g}), got {value!r}")
    return positive(name, value)


def positive_or_inf(name: str, value):
    """`> 0`; `inf` allowed (e.g. no projection)."""
    if not value > 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return value


def non_negative(name: str, value):
    """`>= 0` and finite in float32."""
    if not (value >= 0 and finite_f32(value)):
        raise ValueError(f"{name} must be >= 0 and finite, got {value!r}")
    return value


def finite(name: str, value):
    if not finite_f32(value):
        raise ValueError(f"{name} must be finite in float32, got {value!r}")
    return value


def discount(name: str, value):
    """In `[0, 1)`."""
    if not 0.0 <= value < 1.0:
        raise ValueError(f"{name} must be in [0, 1), got {value!r}")
    return value


def unit_interval(name: str, value):
    """In `[0, 1]`."""
    if not 0.0 <= value <= 1.0:
        raise ValueError(f"{name} must be in [0, 1], got {value!r}")
    return value


def one_of(choices: Sequence[str] | Callable[[], Sequence[str]]) -> Check:
    """A check that the value is one of `choices` (or of what a callable returns when
    checked, for a registry that may grow after import)."""

    def valid() -> tuple[str, ...]:
        return tuple(choices() if callable(choices) else choices)

    def check(name: str, value):
        if value not in valid():
            raise ValueError(f"{name} must be one of {', '.join(valid())}; got {value!r}")
        return value

    check.choices = valid  # what is valid now (the command line's help lists it)
    return check


def optional_point(name: str, value):
    """`None` or a sequence of numbers finite in float32, stored as a tuple of floats."""
    if value is None:
        return None
    point = tuple(float(v) for v in value)
    if not all(finite_f32(v) for v in point):
        raise ValueError(
            f"{name} must be finite in float32 (|x| < {F32_MAX:.4g}), got {list(value)!r}"
        )
    return point


# ----------------------------------------------------------------------------- fields

# JSON spellings of values JSON lacks: `inf` is written as `null`, a tuple as a list.
INF_AS_NONE = (lambda v: None if math.isinf(v) else v, lambda v: math.inf if v is None else v)
TUPLE_AS_LIST = (
    lambda v: None if v is None else list(v),
    lambda v: None if v is None else tuple(v),
)


def field(default, doc: str, check: Check | None = None, json=None):
    """A configuration field: its default, its one-line `doc` (also the command line's
    help), its `check` and, for a value JSON cannot hold, `json` = `(encode, decode)`."""
    return dataclasses.field(default=default, metadata={"doc": doc, "check": check, "json": json})


def frozen_config(cls):
    """Makes `cls` (a `Config` subclass) a frozen dataclass and appends its fields'
    docs to its docstring as its `Attributes:` section."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    lines = [f"  {f.name}: {f.metadata['doc']}" for f in dataclasses.fields(cls)]
    cls.__doc__ = (cls.__doc__ or "").rstrip() + "\n\nAttributes:\n" + "\n".join(lines) + "\n"
    return cls


class Config:
    """A frozen, validated configuration (declare subclasses with `@frozen_config`).

    `validate` (for subclasses) checks what involves several fields, after every field's
    own check has run.
    """

    __dataclass_fields__: ClassVar[dict]

    def __post_init__(self):
        for f in dataclasses.fields(self):
            check = f.metadata.get("check")
            if check is not None:
                object.__setattr__(self, f.name, check(f.name, getattr(self, f.name)))
        self.validate()

    def validate(self) -> None:
        """Checks across fields (raises `ValueError`)."""

    def replace(self, **changes):
        """A copy with `changes` applied (and validated)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """A JSON-friendly dict of every field, in declaration order."""
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            codec = f.metadata.get("json")
            out[f.name] = codec[0](value) if codec else value
        return out

    @classmethod
    def from_dict(cls, d: dict):
        """The inverse of `to_dict`; a field `d` lacks takes its default (a run recorded
        before the field existed ran with what is now its default).

        Raises:
          ValueError: naming a key that is no field.
        """
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - set(fields))
        if unknown:
            raise ValueError(
                f"{cls.__name__} has no field {', '.join(map(repr, unknown))}; "
                f"valid: {', '.join(fields)}"
            )
        values = {}
        for name, value in d.items():
            codec = fields[name].metadata.get("json")
            values[name] = codec[1](value) if codec else value
        return cls(**values)

    @classmethod
    def field_docs(cls) -> dict[str, str]:
        """`{field: doc}` in declaration order."""
        return {f.name: f.metadata["doc"] for f in dataclasses.fields(cls)}
