# mesher/par: the parallel refinement (DESIGN section 5). Uses every layer
# up to refine, and the runtime (libam) and proto.
