"""Rate-neuron circuits: the graph a brain declares (:mod:`.circuit`), the batched arrays it compiles to
(:mod:`.compiled`, built by :mod:`.build` from :mod:`.product`, :mod:`.updates`, :mod:`.noise`,
:mod:`.weights` and :mod:`.inputs`), and what their edges and nodes use (activations, connectivity
rules, encoders, plasticity). Imports the base and :mod:`neuronav.spec` only."""
