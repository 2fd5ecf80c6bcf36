"""The FE of a scene's knee beside its EF answer: the joint path's cross-check and its
balance (`crosscheck`, `balance`), the femoral cartilage as a layer of its own
(`femoral`), the patellar cartilage on a second rigid body (`patella_layer`), and the
knee with menisci with its reports (`knee_menisci`, `knee_menisci_report`)."""
