"""battery_plot.py: a PNG from a replay CSV or a rosbag; one line for bad input."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
plot = pytest.importorskip('battery_simulator.cli.plot', reason='needs the devel space (tools/run_tests.sh)')


def run_plot(*args):
    code = 'from battery_simulator.cli.plot import main; main()'
    return subprocess.run([sys.executable, '-c', code, *map(str, args)], capture_output=True, text=True, timeout=120)


def is_png(path):
    return path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and path.stat().st_size > 10000


def test_a_replay_csv_becomes_a_png_with_status_and_level_marks(tmp_path):
    csv_path = tmp_path / 'run.csv'
    csv_path.write_text('time,voltage,current,soc,temperature,status\n'
                        '0,12.6,-1.5,0.30,25.0,DISCHARGING\n600,11.0,-1.5,0.18,26.0,DISCHARGING\n'
                        '1200,10.0,-1.5,0.04,27.0,DISCHARGING\n1300,9.0,0.0,0.03,26.5,EMPTY\n')
    run = plot.read_replay_csv(csv_path)
    labels = [label for _, label in run.marks]
    assert labels == ['DISCHARGING', 'low', 'critical', 'EMPTY'], labels
    assert run.percentage[0] == pytest.approx(30.0)
    result = run_plot(csv_path, '-o', tmp_path / 'run.png')
    assert result.returncode == 0, result.stderr
    assert is_png(tmp_path / 'run.png')


def test_a_rosbag_of_the_demo_becomes_a_png_with_its_phases():
    run = plot.read_rosbag(ROOT / 'docs' / 'demo_cycle.bag')
    labels = [label for _, label in run.marks]
    for expected in ('GO_TO_DOCK', 'CHARGING', 'UNDOCK', 'FULL', 'low'):
        assert expected in labels, labels
    assert max(run.percentage) > 99.0 and min(run.percentage) < 30.0


@pytest.mark.parametrize('content, expected', [
    (b'time,current\n0,1\n', 'not a battery_replay.py output'),
    (bytes(range(256)), 'not a replay CSV'),
    (b'#ROSBAG V2.0\ngarbage', 'not a readable rosbag'),
])
def test_bad_input_gets_one_line(tmp_path, content, expected):
    path = tmp_path / 'bad'
    path.write_bytes(content)
    result = run_plot(path, '-o', tmp_path / 'out.png')
    assert result.returncode == 1 and expected in result.stderr, result.stderr
    assert 'Traceback' not in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert run_plot(tmp_path / 'absent.csv').returncode == 1


def test_marks_at_the_same_moment_become_one_label():
    marks = [(53.0, 'FULL'), (53.2, 'UNDOCK'), (0.0, 'DISCHARGING'), (0.1, 'low'), (30.0, 'CHARGING')]
    assert plot.merged_marks(marks, 100.0) == [(0.0, 'DISCHARGING, low'), (30.0, 'CHARGING'), (53.0, 'FULL, UNDOCK')]
    assert plot.merged_marks(marks, 1.0) == sorted(marks)
    assert plot.merged_marks([(5.0, 'CHARGING'), (5.1, 'CHARGING')], 100.0) == [(5.0, 'CHARGING')]


def test_a_replay_of_a_pack_of_groups_draws_the_cell_spread_and_the_gauge(tmp_path):
    csv_path = tmp_path / 'aged.csv'
    csv_path.write_text('time,voltage,current,soc,temperature,status,cell_voltage_min,cell_voltage_max,gauge_soc\n'
                        '0,28.0,-5,0.90,25.0,DISCHARGING,3.99,4.01,0.92\n'
                        '1800,26.0,-5,0.60,26.0,DISCHARGING,3.70,3.74,0.64\n'
                        '3600,24.0,-5,0.30,27.0,DISCHARGING,3.50,3.58,0.36\n')
    run = plot.read_replay_csv(csv_path)
    assert run.gauge == pytest.approx([92.0, 64.0, 36.0]) and run.cells[1][2] == pytest.approx(3.58)
    result = run_plot(csv_path, '-o', tmp_path / 'aged.png')
    assert result.returncode == 0, result.stderr
    assert is_png(tmp_path / 'aged.png')


def test_low_and_critical_are_marked_where_the_gauge_crosses_them_not_the_truth(tmp_path):
    """Issue 33 item 8: what the robot saw is the gauge; the truth (soc) crossed 20 % an hour earlier."""
    csv_path = tmp_path / 'gauge.csv'
    csv_path.write_text('time,voltage,current,soc,temperature,status,cell_voltage_min,cell_voltage_max,gauge_soc\n'
                        '0,11.5,-1.5,0.30,25.0,DISCHARGING,3.80,3.84,0.40\n'
                        '3600,11.0,-1.5,0.15,25.0,DISCHARGING,3.60,3.64,0.26\n'
                        '7200,10.5,-1.5,0.03,25.0,DISCHARGING,3.40,3.46,0.12\n'
                        '9000,10.0,-1.5,0.00,25.0,EMPTY,3.20,3.30,0.04\n')
    run = plot.read_replay_csv(csv_path)
    events = [(t, label) for t, label in run.marks if label in ('low', 'critical')]
    assert events == [(7200.0, 'low'), (9000.0, 'critical')], run.marks
    run = plot.read_replay_csv(csv_path, low=0.3, critical=0.13)
    assert [(t, label) for t, label in run.marks if label in ('low', 'critical')] == \
        [(3600.0, 'low'), (7200.0, 'critical')], 'the thresholds given'


def test_a_bag_of_the_gauge_demo_has_the_truth_the_cells_and_the_events():
    run = plot.read_rosbag(ROOT / 'docs' / 'demo_gauge.bag', low=0.25)
    assert run.truth is not None and len(run.truth[0]) > 100, 'battery_simulator/state true_percentage'
    assert run.cells is not None and len(run.cells[0]) == len(run.time)
    assert all(low <= high for low, high in zip(*run.cells))
    labels = [label for _, label in run.marks]
    assert 'low' in labels and 'GO_TO_DOCK' in labels, labels


def test_the_labels_of_close_marks_never_overlap(tmp_path):
    """Issue 33 item 8: in docs/demo_gauge.png the phase labels printed over one another. Marks a few
    seconds apart (a status and a phase) get lanes of their own; marks at one moment share one label."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    marks = [(0.0, 'DISCHARGING'), (1.0, 'PATROL'), (700.0, 'low'), (705.0, 'GO_TO_DOCK'), (715.0, 'CHARGING'),
             (718.0, 'CHARGING'), (6172.0, 'FULL'), (6184.0, 'UNDOCK'), (6192.0, 'DISCHARGING'), (6208.0, 'PATROL')]
    figure, (strip, axis) = pyplot.subplots(2, 1, figsize=(10, 4))
    axis.plot([0.0, 7000.0], [0.0, 1.0])
    texts = plot._label_strip(figure, strip, marks, 1.0, axis)
    renderer = figure.canvas.get_renderer()
    boxes = [text.get_window_extent(renderer) for text in texts]
    assert len(boxes) == len(plot.merged_marks(marks, 6208.0, plot.SAME_MOMENT)) >= 6
    for index, box in enumerate(boxes):
        for other in boxes[index + 1:]:
            assert not box.overlaps(other), [t.get_text() for t in texts]
    pyplot.close(figure)


def test_the_plot_draws_cells_cut_off_and_the_levels(tmp_path):
    csv_path = tmp_path / 'cells.csv'
    csv_path.write_text('time,voltage,current,soc,temperature,status,cell_voltage_min,cell_voltage_max,gauge_soc\n'
                        '0,11.5,-1.5,0.30,25.0,DISCHARGING,3.80,3.84,0.40\n'
                        '3600,10.0,0,0.0,25.0,EMPTY,2.50,2.60,0.0\n')
    result = run_plot(csv_path, '-o', tmp_path / 'cells.png', '--preset', 'lg_hg2_3s1p', '--low', '0.25')
    assert result.returncode == 0, result.stderr
    assert is_png(tmp_path / 'cells.png')
    for args, named in ((('--low', '2'), '--low'), (('--preset', 'nope'), 'preset')):
        result = run_plot(csv_path, '-o', tmp_path / 'x.png', *args)
        assert result.returncode != 0 and named in result.stderr and len(result.stderr.strip().splitlines()) == 1, \
            result.stderr


def test_a_learning_gauges_corrections_are_drawn(tmp_path):
    """Issue 43 item 4: a replay's gauge_event and gauge_full_capacity_ah: each correction where the gauge was
    after it, the learned capacity's value, the 99 % hold shaded."""
    csv_path = tmp_path / 'day.csv'
    csv_path.write_text('time,voltage,current,soc,temperature,status,cell_voltage_min,cell_voltage_max,gauge_soc,'
                        'gauge_full_capacity_ah,gauge_event\n'
                        '0,11.5,0,0.50,25.0,NOT_CHARGING,3.74,3.74,0.55,3.0590,\n'
                        '1800,11.5,0,0.50,25.0,NOT_CHARGING,3.74,3.74,0.494,3.0590,ocv_rest\n'
                        '3600,12.5,0.2,0.98,25.0,CHARGING,4.2,4.2,0.99,3.0590,\n'
                        '3700,12.5,0.2,0.985,25.0,CHARGING,4.2,4.2,0.99,3.0590,\n'
                        '3800,12.6,0,1.0,25.0,FULL,4.2,4.2,1.0,2.7900,capacity_learned;end_of_charge\n')
    run = plot.read_replay_csv(csv_path)
    assert run.gauge_events == [(1800.0, 'ocv_rest'), (3800.0, 'capacity_learned'), (3800.0, 'end_of_charge')]
    assert run.gauge_capacity[-1] == pytest.approx(2.79)
    result = run_plot(csv_path, '-o', tmp_path / 'day.png')
    assert result.returncode == 0, result.stderr
    assert is_png(tmp_path / 'day.png')
