"""FE materials: the stiffness of isotropic linear elastic solids, with the mixed form
that keeps near-incompressible layers from locking (`elasticity`), and of transversely
isotropic ones, the menisci with their fibres (`anisotropy`)."""
