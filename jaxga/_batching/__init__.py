"""Private batching machinery: what keeps batched programs flat and their bits batch-independent.

- :mod:`~jaxga._batching.folding`: every ``vmap`` level of a call folded into one batch;
- :mod:`~jaxga._batching.scatter`: scatters that stay one flat scatter under ``vmap``;
- :mod:`~jaxga._batching.lanes`: a ``while_loop`` whose unfinished lanes are compacted;
- :mod:`~jaxga._batching.numerics`: sums whose rounding does not depend on the batch.

Not a public interface: the operators and the engine use it.
"""
