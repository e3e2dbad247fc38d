"""The base of every deck model (mpmsim/deck/schema.py, the material models in mpmsim/materials):
unknown keys are errors, and so are NaN, infinities and magnitudes no physical input reaches."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, field_validator

Vector = list[float]

MAX_MAGNITUDE = 1e30  # no physical input in any unit system comes near; squares of it still fit a float


def _too_large(v) -> float | None:
    if isinstance(v, float) and abs(v) > MAX_MAGNITUDE:
        return v
    if isinstance(v, (list, tuple)):
        for item in v:
            bad = _too_large(item)
            if bad is not None:
                return bad
    return None


class Strict(BaseModel):
    # unknown keys are errors; NaN and +-inf are refused in every number (they would crash later)
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    @field_validator("*", mode="after")
    @classmethod
    def _plausible_magnitude(cls, v):
        bad = _too_large(v)
        if bad is not None:
            raise ValueError(f"{bad:g} is beyond +-{MAX_MAGNITUDE:g}, which no physical input reaches")
        return v
