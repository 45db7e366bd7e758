"""Display units: code, messages and config are SI; bar and L/min appear only in reports,
plots and the console, converted with these constants."""

PA_PER_BAR = 1.0e5          # 1 bar in Pa
LPM_PER_M3S = 60000.0       # L/min in 1 m^3/s
L_PER_M3 = 1000.0            # L in 1 m^3
PA_PER_KPA = 1.0e3          # 1 kPa in Pa (WITS, LAS and WITSML logs)
