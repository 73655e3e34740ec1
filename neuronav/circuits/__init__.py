"""Rate-neuron circuits: the graph a brain declares (:mod:`.circuit`), the batched arrays it compiles to
(:mod:`.compiled`), and what their edges and nodes use (activations, connectivity rules, encoders,
plasticity). Imports the base and :mod:`neuronav.spec` only."""
