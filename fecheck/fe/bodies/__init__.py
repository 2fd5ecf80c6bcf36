"""The bodies the FE builds from a scene: its ``[fe]`` options (`settings`), the tibial
surfaces and the femoral indenters (`scene_bodies`, `indenter`), the extruded layers and
closed solids (`solid`, `volume`), the menisci's solids (`meniscus_solid`), their size
guard (`budget`) and rigid poses that name their frames (`pose`)."""
