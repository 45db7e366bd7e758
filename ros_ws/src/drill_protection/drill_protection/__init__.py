"""Process protection between the advisors (controller, operator) and the machines (DESIGN section 10)."""
