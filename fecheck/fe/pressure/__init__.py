"""What a contact solve's nodal forces become: the pressure field, its area, peaks and
metrics (`recovery`), and the plain records of an FE answer (`results`)."""
