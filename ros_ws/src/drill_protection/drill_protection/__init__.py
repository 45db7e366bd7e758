"""Process protection between the advisors (controller, operator) and the machines (docs/design.md §10)."""
