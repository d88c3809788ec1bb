"""The Eulerian two-phase model (``model.name = two_phase``): the granular material and a
passive light fluid on a fixed box mesh, told apart by the granular volume fraction c
(seed 003's Gerris/Basilisk method): ``fraction`` (c, its initial value and advection),
``flow`` (the Picard step of the mixture, then c), ``adapter`` (the loop's protocols)."""
