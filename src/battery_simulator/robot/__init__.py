"""The demo robot's side: a kinematic base, the dock contact, the cut-off gate, patrol and dock."""
