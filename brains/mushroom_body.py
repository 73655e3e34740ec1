"""The mushroom body: a view's familiarity from a sparse Kenyon-cell code and one-shot depression.

After Ardin et al. 2016 and Sun et al. 2020 (``docs/parameters.md`` §9):

- **PN** (projection neurons, an ``input`` population): one view's code, z-scored across its
  values (:func:`pn_code`), either a down-sampled grey panorama (:func:`panorama_code`, Ardin's
  low-resolution view; it turns with the viewer, so familiarity depends on heading) or the
  amplitudes of the panorama's Zernike moments (:func:`zernike_code`, Sun's 81 inputs; rotation
  invariant).
- **KC** (Kenyon cells, binary): each reads ``inputs_per_kc`` PNs drawn at random without
  replacement (seeded, :func:`kc_wiring`), weight 1, and fires (rate 1) where the sum exceeds
  ``kc_threshold``. With z-scored inputs the threshold sets the code's sparsity
  (:func:`kc_sparsity` measures it); the default gives a few per cent of the KCs active on the
  forest views of ``scenarios/tools/mb_familiarity.py`` (measured there and in
  ``tests/unit/test_mushroom_body.py``).
- **MBON** (one output neuron, motor port ``novelty``): Σ w_k KC_k with every w_k = 1 at first.
  While the ``learning`` port is on (> 0.5) the KC→MBON connection learns by
  :class:`~neuronav.circuits.plasticity.OneShotDepression`: every active KC's weight drops by
  ``learning_rate`` (1 by default: one presentation silences it), floored at 0. The output is the
  number of active KCs whose weights are intact: the view's novelty (0: fully familiar).
"""

from __future__ import annotations

import numpy as np

from neuronav.circuits.circuit import Circuit
from neuronav.circuits.plasticity import OneShotDepression
from neuronav.errors import ConfigError
from neuronav.spec.ports import MotorSpec, SensorSpec

N_KC = 4000  # Sun et al. 2020
INPUTS_PER_KC = 10  # Ardin et al. 2016; Sun et al. 2020
N_ZERNIKE = 81  # amplitudes of the Zernike moments up to order 16
# KC threshold on the sum of 10 z-scored inputs: a few per cent of the KCs active on forest views
# (panorama code; measured by tests/unit/test_mushroom_body.py).
KC_THRESHOLD = 6.0
PANORAMA_COLUMNS, PANORAMA_ROWS = 36, 9  # 10° blocks of the upper hemisphere: 324 PNs
# Size bounds (25 times Sun's 4000 KCs): the KC wiring draws one KC at a time (about 2 s for
# MAX_KC), and its dense PN->KC matrix stays under 256 MB of float64.
MAX_KC = 100_000
MAX_KC_WEIGHTS = 2 ** 25


def kc_wiring(n_kc: int, n_pn: int, inputs_per_kc: int, seed: int) -> np.ndarray:
    """KC←PN weights (n_kc, n_pn): each KC reads ``inputs_per_kc`` distinct PNs at random, weight 1."""
    rng = np.random.default_rng(seed)
    weights = np.zeros((n_kc, n_pn))
    rows = np.repeat(np.arange(n_kc), inputs_per_kc)
    columns = np.concatenate([rng.choice(n_pn, inputs_per_kc, replace=False) for _ in range(n_kc)])
    weights[rows, columns] = 1.0
    return weights


def pn_code(values) -> np.ndarray:
    """Each view's values (N, n) z-scored across its n values (zero mean, unit variance; a uniform view: 0)."""
    values = np.asarray(values, float)
    if values.ndim != 2 or not np.isfinite(values).all():
        raise ConfigError(f"pn_code: needs finite values of shape (views, n), got shape {values.shape}")
    centred = values - values.mean(axis=1, keepdims=True)
    spread = centred.std(axis=1, keepdims=True)
    return np.divide(centred, spread, out=np.zeros_like(centred), where=spread > 1e-12)


def panorama_code(panorama, columns: int = PANORAMA_COLUMNS, rows: int = PANORAMA_ROWS) -> np.ndarray:
    """The PN code (N, rows * columns) of grey panoramas (N, H, W): the upper half (zenith to horizon)
    averaged over ``rows`` x ``columns`` blocks, then z-scored (:func:`pn_code`).

    H / 2 must be a multiple of ``rows`` and W of ``columns``.
    """
    images = np.asarray(panorama, float)
    images = images[None] if images.ndim == 2 else images
    if images.ndim != 3:
        raise ConfigError(f"panorama_code: needs grey panoramas (N, H, W), got shape {np.shape(panorama)}")
    n, height, width = images.shape
    half = height // 2
    if half % rows or width % columns:
        raise ConfigError(f"panorama_code: {rows} rows x {columns} columns must divide the upper half "
                          f"{half} x {width} px evenly")
    blocks = images[:, :half].reshape(n, rows, half // rows, columns, width // columns).mean(axis=(2, 4))
    return pn_code(blocks.reshape(n, -1))


def zernike_code(panorama, basis) -> np.ndarray:
    """The PN code (N, len(basis.orders)) of grey panoramas: the logarithms of the Zernike amplitudes
    (:class:`neuronav.brains.vision.ZernikeBasis`, n_max 16 gives 81), z-scored.

    The logarithm (of the amplitude plus 0.1 % of the view's mean amplitude) is this module's choice:
    the low orders' amplitudes are orders of magnitude larger than the rest, so z-scored raw
    amplitudes drive every KC that reads one of them (13 % active at the default threshold on forest
    views, against 2.6 % with the logarithm).
    """
    amplitudes = basis.amplitudes(panorama)
    return pn_code(np.log(amplitudes + 1e-3 * amplitudes.mean(axis=1, keepdims=True) + 1e-300))


def mushroom_body(n_pn: int = N_ZERNIKE, n_kc: int = N_KC, inputs_per_kc: int = INPUTS_PER_KC,
                  kc_threshold: float = KC_THRESHOLD, learning_rate: float = 1.0, seed: int = 0) -> Circuit:
    """The mushroom body as a circuit (see the module doc).

    Parameters
    ----------
    n_pn : int
        Projection neurons: the length of the view code on port ``pn`` (81 Zernike amplitudes by
        default; ``PANORAMA_ROWS * PANORAMA_COLUMNS`` = 324 for :func:`panorama_code`).
    n_kc : int
        Kenyon cells (1 to :data:`MAX_KC`, with ``n_kc * n_pn`` at most :data:`MAX_KC_WEIGHTS`).
    inputs_per_kc : int
        PNs each KC reads (1..n_pn).
    kc_threshold : float
        A KC fires where its summed input exceeds this.
    learning_rate : float
        Weight lost by an active KC's synapse per step with learning on (> 0).
    seed : int
        Seeds the KC wiring: the same seed, the same mushroom body.

    Ports: sensors ``pn`` (n_pn,) and ``learning`` (1,) (> 0.5: learn this view); motor ``novelty`` (1,).
    """
    for label, value, lowest in (("n_pn", n_pn, 1), ("n_kc", n_kc, 1), ("inputs_per_kc", inputs_per_kc, 1),
                                 ("seed", seed, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lowest:
            raise ConfigError(f"mushroom_body: {label} must be an int >= {lowest}, got {value!r}")
    if n_kc > MAX_KC or n_kc * n_pn > MAX_KC_WEIGHTS:
        raise ConfigError(f"mushroom_body: n_kc ({n_kc}) must be at most {MAX_KC} and n_kc * n_pn ({n_kc * n_pn}) "
                          f"at most {MAX_KC_WEIGHTS} (the PN->KC weights' memory bound)")
    if inputs_per_kc > n_pn:
        raise ConfigError(f"mushroom_body: inputs_per_kc ({inputs_per_kc}) cannot exceed n_pn ({n_pn})")
    for label, value in (("kc_threshold", kc_threshold), ("learning_rate", learning_rate)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not np.isfinite(value):
            raise ConfigError(f"mushroom_body: {label} must be a finite number, got {value!r}")
    if not learning_rate > 0:
        raise ConfigError(f"mushroom_body: learning_rate must be > 0, got {learning_rate!r}")
    circuit = Circuit("mushroom_body")
    circuit.add_input("PN", n_pn, ports=[SensorSpec("pn", (n_pn,), "z-scored view code")])
    circuit.add_input("learning", 1, ports=[SensorSpec("learning", (1,), "gate (> 0.5: learn)")])
    circuit.add_population("KC", n_kc, activation="step", params={"threshold": float(kc_threshold)})
    circuit.connect("PN", "KC", weights=kc_wiring(n_kc, n_pn, inputs_per_kc, seed))
    circuit.add_output("MBON", 1, MotorSpec("novelty", (1,), "active KCs with intact weights"))
    circuit.connect("KC", "MBON", weights=np.ones((1, n_kc)),
                    learning=OneShotDepression(rate=float(learning_rate), gate="learning"))
    return circuit


def kc_sparsity(compiled) -> np.ndarray:
    """The fraction of KCs active (N,) in each agent's last step of a compiled mushroom body."""
    return compiled.rates("KC").mean(axis=1)


def _check_codes(where: str, compiled, codes) -> np.ndarray:
    """``codes`` as a finite float array (V, n_pn) for ``compiled``'s ``pn`` port, or a ConfigError."""
    n_pn = next(s.shape[0] for s in compiled.sensors if s.name == "pn")
    try:
        array = np.asarray(codes, float)
    except (TypeError, ValueError):
        array = np.full(0, np.nan)
    if array.ndim != 2 or array.shape[1] != n_pn or not np.isfinite(array).all():
        raise ConfigError(f"{where}: codes must be finite numbers of shape (views, {n_pn}), got "
                          f"{'non-finite values' if array.shape[1:] == (n_pn,) else f'shape {np.shape(codes)}'}")
    return array


def learn_views(compiled, codes: np.ndarray) -> None:
    """Store views one after another (learning on), every agent of ``compiled`` the same views.

    ``codes`` (V, n_pn): one step per view, finite (else a ConfigError).
    """
    codes = _check_codes("learn_views", compiled, codes)
    gate = np.ones((compiled.batch, 1))
    for code in codes:
        compiled.step({"pn": np.broadcast_to(code, (compiled.batch, code.size)), "learning": gate})


def novelty(compiled, codes: np.ndarray) -> np.ndarray:
    """The novelty (V,) of each view for agent 0's memory, learning off (``compiled`` is left unchanged
    apart from its rates).

    The views are evaluated ``compiled.batch`` at a time, each batch slot holding agent 0's weights
    (restored afterwards): the per-agent weights let one learnt memory judge many views in one step.
    ``codes`` (V, n_pn), finite (else a ConfigError).
    """
    codes = _check_codes("novelty", compiled, codes)
    name = "KC->MBON"
    saved = compiled.weights(name)
    compiled.set_weights(name, saved[:1])
    batch = compiled.batch
    out = np.empty(len(codes))
    gate = np.zeros((batch, 1))
    try:
        for start in range(0, len(codes), batch):
            chunk = codes[start:start + batch]
            padded = np.zeros((batch, codes.shape[1]))
            padded[:len(chunk)] = chunk
            out[start:start + len(chunk)] = compiled.step({"pn": padded, "learning": gate})["novelty"][:len(chunk), 0]
    finally:
        compiled.set_weights(name, saved)
    return out
