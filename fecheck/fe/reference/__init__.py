"""FE problems with a known answer: the axisymmetric sphere on a bonded layer (`axisym`),
the same problem through the 3-D path (`sphere_layer`) and the ring meniscus
(`ring_meniscus`)."""
