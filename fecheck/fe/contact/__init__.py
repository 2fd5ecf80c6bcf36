"""The FE contact core: condensed compliance of each body (`compliance`), the
node-to-surface gap operator and a deformable master's give (`gap`), the active-set
solve of the complementarity problem (`active_set`), the candidate-widening rounds
(`candidates`) and the single-indenter solve of the axisymmetric reference
(`load_control`)."""
