"""The operator's side of the rig: the web console, its state and form validation, the operator command line."""
