"""The 1D spurious-reflection study of the paper's §4 (Figs. 4–7): the model's description
(spec), its energies, one coupled run (model), the sweep (study) and its figures (plots)."""
from cases.wave1d.energy import lattice_energy, weighted_invariant
from cases.wave1d.model import (Wave1DResult, bar_model, bar_stations, chain_critical_dt, run,
                                result_line, run_to_folder, summarise)
from cases.wave1d.plots import plot_study, plot_wave
from cases.wave1d.spec import C, E, RHO, Layout, Wave1DSpec
from cases.wave1d.study import (AUTO_RATIOS, STUDY_LAYERS, STUDY_RELAXATIONS, markdown_table,
                                run_study, study_cases)
