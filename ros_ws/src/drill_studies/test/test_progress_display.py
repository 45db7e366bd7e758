"""Progress: rig run's from the plant's marker lines (drill_ros.progress), rig compare's and
rig sweep's runs done (drill_studies.batch.Progress). The marker a
plant prints every 10 s simulated is found at the end of a log with other lines after
it; on a terminal one line rewritten in place, in a log a plain line every 100 s
simulated; nothing before the first marker."""
import io

from drill_bringup.progress_display import ProgressDisplay
from drill_ros import progress


def test_the_plant_prints_a_marker_every_ten_simulated_seconds(capsys):
    plant = progress.PlantProgress(sensor_period_s=0.1, duration_s=600.0)
    for k in range(1, 251):
        plant.frame_done(k)
    lines = capsys.readouterr().out.splitlines()
    assert lines == ["SIMULATED_S 10.0 600.0", "SIMULATED_S 20.0 600.0"]


def test_the_last_marker_is_read_from_the_log_end(tmp_path):
    log = tmp_path / "plant.log"
    assert progress.last_marker(log) is None                        # no log yet
    log.write_text("[INFO] graph connected\n")
    assert progress.last_marker(log) is None
    log.write_text("x" * 10000 + "\n" + progress.marker(20.0, 600.0) + "\n"
                   + progress.marker(30.0, 600.0) + "\n[INFO] frame late\n")
    assert progress.last_marker(log) == (30.0, 600.0)


class Clock:
    def __init__(self):
        self.now_s = 100.0

    def __call__(self):
        return self.now_s


def feed(tmp_path, terminal):
    log, out, clock = tmp_path / "plant.log", io.StringIO(), Clock()
    display = ProgressDisplay(log, started_s=100.0, terminal=terminal, out=out, clock=clock)
    for simulated_s in (10.0, 20.0, 90.0, 100.0, 110.0, 200.0):
        with open(log, "a") as f:
            f.write(progress.marker(simulated_s, 600.0) + "\n")
        clock.now_s += 2.0
        display.poll()
    display.close()
    return out.getvalue()


def test_a_terminal_gets_one_line_rewritten_in_place(tmp_path):
    text = feed(tmp_path, terminal=True)
    assert text.count("\r") == 6 and text.endswith("\n") and text.count("\n") == 1
    assert text.rstrip().endswith("200 / 600 s simulated, 12 s wall, real-time factor 0.060")


def test_a_log_gets_a_plain_line_every_hundred_simulated_seconds(tmp_path):
    lines = feed(tmp_path, terminal=False).splitlines()
    assert [line.split(" / ")[0] for line in lines] == ["[rig] 100", "[rig] 200"]


def test_a_batch_in_a_log_prints_runs_done_and_the_time_left():
    from drill_studies.batch import Progress
    out, clock = io.StringIO(), Clock()
    progress = Progress(4, stream=out, clock=clock)
    for _ in range(2):
        clock.now_s += 60.0
        progress.step()
    progress.close()
    assert out.getvalue().splitlines() == ["[batch] 1 / 4 runs, 60 s, about 180 s left",
                                           "[batch] 2 / 4 runs, 120 s, about 120 s left"]
