"""Display units: code, messages and config are SI; bar and L/min appear only in reports,
plots and the console, converted with these constants."""

PA_PER_BAR = 1.0e5          # 1 bar in Pa
LPM_PER_M3S = 60000.0       # L/min in 1 m^3/s
L_PER_M3 = 1000.0            # L in 1 m^3
PA_PER_KPA = 1.0e3          # 1 kPa in Pa (WITS, LAS and WITSML logs)
N_PER_KN = 1.0e3            # 1 kN in N (the logs' hook load)

# The console's unit systems (the display edge only): quantity -> (symbol, value in that
# unit of 1 SI unit). Field units: psi = 6894.757293168 Pa, US gallon = 3.785411784 L,
# ppg = 119.8264273 kg/m^3, ft = 0.3048 m, bbl = 0.158987294928 m^3.
DISPLAY_UNITS = {
    "metric": {"pressure": ("bar", 1.0 / PA_PER_BAR), "flow": ("L/min", LPM_PER_M3S),
               "gain": ("L", L_PER_M3),
               "density": ("s.g.", 1.0e-3), "length": ("m", 1.0), "volume": ("m³", 1.0),
               "velocity": ("m/s", 1.0), "force": ("kN", 1.0e-3)},
    "field": {"pressure": ("psi", 1.0 / 6894.757293168), "gain": ("bbl", 1.0 / 0.158987294928),
              "flow": ("gpm", LPM_PER_M3S / 3.785411784), "density": ("ppg", 1.0 / 119.8264273),
              "length": ("ft", 1.0 / 0.3048), "volume": ("bbl", 1.0 / 0.158987294928),
              "velocity": ("ft/s", 1.0 / 0.3048), "force": ("klbf", 1.0 / 4448.2216152605)},
}


class Display:
    """One of DISPLAY_UNITS's systems, for a report's text and plots: ``factor`` turns an
    SI value of a quantity into the system's unit, ``symbol`` names it."""

    def __init__(self, system: str = "metric"):
        if system not in DISPLAY_UNITS:
            raise ValueError(f"units: value {system!r} is not one of {', '.join(DISPLAY_UNITS)}")
        self.system = system

    def factor(self, quantity: str) -> float:
        return DISPLAY_UNITS[self.system][quantity][1]

    def symbol(self, quantity: str) -> str:
        return DISPLAY_UNITS[self.system][quantity][0]


METRIC_DISPLAY = Display("metric")   # the reports' default
