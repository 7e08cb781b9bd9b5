"""The entropy coefficient ``ent_coef`` of a loaded SAC-family model, set from a fine-tune's hyperparameters.

SAC, TQC and the JAX learners (:data:`ENTROPY_ALGOS`) either learn the coefficient (``auto``,
``auto_<initial value>``: a log-coefficient and its own optimiser) or hold it fixed (a number). The
libraries' ``load`` restores the checkpoint's choice and state, so it cannot switch between the two (it
fails on the missing or extra optimiser) and ignores a new fixed value. :func:`set_ent_coef`
sets it on the loaded model instead:

* a number ``c >= 0``: the coefficient is ``c``, fixed;
* ``auto``: learned, continuing from the checkpoint's coefficient (its learned value and optimiser
  state, or its fixed value with a new optimiser);
* ``auto_<x>`` (``x > 0``): learned, starting anew from ``x``.
"""

from __future__ import annotations

from .zoo_config import JAX_ALGOS, checked_number

#: the algorithms whose ``ent_coef`` is learned or fixed (PPO's is a plain loss weight)
ENTROPY_ALGOS = ("sac", "tqc", *JAX_ALGOS)

_MESSAGE = "ent_coef must be 'auto', 'auto_<initial value > 0>' or a number >= 0, got {!r}"


def checked_ent_coef(value) -> str | float:
    """``value`` as :func:`set_ent_coef` takes it (``auto``, ``auto_<x>`` with ``x > 0``, or a
    number ``>= 0`` as a float); ValueError (one line) otherwise."""
    if isinstance(value, str) and value.startswith("auto"):
        if value != "auto":
            prefix, _, x = value.partition("_")
            checked_number(x if prefix == "auto" else None, lambda v: v > 0.0, _MESSAGE.format(value))
        return value
    return checked_number(value, lambda v: v >= 0.0, _MESSAGE.format(value))


def set_ent_coef(model, value) -> None:
    """Set the entropy coefficient of the loaded ``model`` (SB3's or ``sbx``'s SAC, TQC or CrossQ)
    to ``value`` (:func:`checked_ent_coef`; the module docstring says what each form does)."""
    value = checked_ent_coef(value)
    learned = isinstance(value, str)
    start = current_ent_coef(model) if value == "auto" else float(value.split("_")[1]) if learned else value
    if hasattr(model, "ent_coef_state"):
        _set_jax(model, value, learned, start)
    else:
        _set_torch(model, value, learned, start)


def current_ent_coef(model) -> float:
    """The entropy coefficient ``model`` trains with now."""
    if hasattr(model, "ent_coef_state"):
        state = model.ent_coef_state
        return float(state.apply_fn({"params": state.params}))
    import torch as th

    if model.log_ent_coef is not None:
        return float(th.exp(model.log_ent_coef.detach()))
    return float(model.ent_coef_tensor)


def _set_torch(model, value, learned: bool, start: float) -> None:
    import torch as th

    if value == "auto" and model.ent_coef_optimizer is not None:
        model.ent_coef = value  # already learned: its log-coefficient and optimiser state go on
        return
    model.ent_coef = value
    if learned:
        model.log_ent_coef = th.log(th.full((1,), start, device=model.device)).requires_grad_(True)
        model.ent_coef_optimizer = th.optim.Adam([model.log_ent_coef], lr=model.lr_schedule(1))
    else:
        model.log_ent_coef, model.ent_coef_optimizer = None, None
        model.ent_coef_tensor = th.tensor(start, device=model.device)


def _set_jax(model, value, learned: bool, start: float) -> None:
    import jax
    import optax
    from flax.training.train_state import TrainState
    from sbx.sac.sac import ConstantEntropyCoef, EntropyCoef

    if value == "auto" and "log_ent_coef" in model.ent_coef_state.params:
        model.ent_coef_init = value  # already learned: its state goes on
        return
    model.ent_coef_init = value  # what the model saves and a later load rebuilds from
    model.ent_coef = EntropyCoef(start) if learned else ConstantEntropyCoef(start)
    model.ent_coef_state = TrainState.create(
        apply_fn=model.ent_coef.apply,
        params=model.ent_coef.init(jax.random.PRNGKey(0))["params"],
        tx=optax.adam(learning_rate=model.lr_schedule(1)),
    )
