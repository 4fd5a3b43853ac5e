"""Model-form uncertainty: the alternatives to the chosen model that the data hardly tell apart
from it, and how far each would move the course (issue 46).

The analysis chooses an effect's shape (a reflex's delay, direction and activation) by its marginal
likelihood, and an effect in or out of the model by the user's ``--effect``; the winner was so far
treated as certain. Here each alternative of comparable evidence gets its posterior weight (the
marginal likelihoods, uniform prior over the candidates; the chosen model holds the rest) and its
course less the chosen one's, on the trial's samples: :class:`~limbstiff.band.ModelForm`, whose
spread the band and the trial-level figures carry. The alternatives are

* the other shapes of each effect in the model within
  :data:`~limbstiff.effects.in_model.EVIDENCE_SPAN` of the chosen one (their amplitude the
  least-squares match of the chosen torque);
* each effect in the model left out (its evidence the likelihood it gained less ln of its grid's
  size: the prior spreads the effect over its shapes);
* without effects, the library's reflex put in, as the ``reflex`` check's probe finds it.

The model's other coefficients (m, b) are kept at their values for the shapes' alternatives (they
move little between neighbouring shapes); the probe's and the left-out effect's changes come from
the estimate's sensitivities, m and b moved. Cost: one smoother pass per kept shape (at most
:data:`~limbstiff.effects.in_model.ALTERNATIVES_MAX` per effect) and one course per alternative
in memory. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from ..band import ModelForm
from ..mechanics.effect_terms import EffectTerms
from ..statespace.linear import course_response
from ..statespace.noise import NoiseLevels
from ..statespace.smoother import to_samples
from ..statespace.steps import ModelSteps


def _on_samples(steps: ModelSteps, values: np.ndarray, n: int) -> np.ndarray:
    """Values at the model's (regular) steps, shape (k, m), interpolated onto the n samples."""
    idx = steps.index
    back = to_samples(n, int(idx[0]), int(idx[1] - idx[0]) if len(idx) > 1 else 1, len(idx))
    return np.vstack([back(v) for v in values])


def effects_form(effects: EffectTerms, amplitudes: np.ndarray, sensitivity: np.ndarray, *, steps: ModelSteps,
                 noise: NoiseLevels) -> tuple[list[float], list[np.ndarray]]:
    """The alternatives of the effects in the model (module docstring).

    Parameters
    ----------
    effects : EffectTerms
        The effects in the model, with their alternatives.
    amplitudes : ndarray, shape (k,)
        Their identified amplitudes.
    sensitivity : ndarray, shape (k, n)
        ∂σ̂/∂(each amplitude) on the samples.
    steps : ModelSteps
        The estimate's steps (z on the signals the spring is left to explain).
    noise : NoiseLevels

    Returns
    -------
    log_evidence : list of float
        Each alternative's log marginal likelihood less the chosen model's.
    changes : list of ndarray, shape (n,)
        Each one's course less the chosen one's, N·m/rad (N/m).
    """
    n = sensitivity.shape[1]
    logs, changes = [], []
    for k, (a, column) in enumerate(zip(amplitudes, effects.columns)):
        gain = effects.loglik_gains[k] if k < len(effects.loglik_gains) else None
        tried = effects.shapes_tried[k] if k < len(effects.shapes_tried) else 1
        if gain is not None:
            logs.append(-(float(gain) - np.log(max(tried, 1))))
            changes.append(-a * sensitivity[k])
        alternatives = effects.alternatives[k] if k < len(effects.alternatives) else ()
        if not alternatives:
            continue
        at = steps.index
        rows = []
        for delta, other in alternatives:
            match = a * float(column[at] @ other[at]) / max(float(other[at] @ other[at]), 1e-300)
            rows.append(a * column[at] - match * other[at])          # z under it less z under the chosen
            logs.append(float(delta))
        changes += list(_on_samples(steps, course_response(steps, np.vstack(rows), noise), n))
    return logs, changes


def model_form(log_evidence: list[float], changes: list[np.ndarray]) -> ModelForm | None:
    """The alternatives' weights e^ℓ / (1 + Σ e^ℓ) (the chosen model's ℓ = 0) and changes as a
    :class:`ModelForm`; None without alternatives or where none weighs 10⁻⁶."""
    if not changes:
        return None
    logs = np.clip(np.asarray(log_evidence, dtype=float), -700.0, 700.0)
    top = max(0.0, float(logs.max()))
    weights = np.exp(logs - top) / (np.exp(-top) + np.sum(np.exp(logs - top)))
    keep = weights > 1e-6
    if not keep.any():
        return None
    return ModelForm(weights=weights[keep], changes=np.vstack([c for c, k in zip(changes, keep) if k]))
