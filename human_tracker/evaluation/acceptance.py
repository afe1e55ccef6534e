"""The bars of the issues, checked on a ``make bench`` run's results: one row per bar with the
figure, the bar and whether it is met (:func:`acceptance_rows`)."""

from __future__ import annotations

from human_tracker.vision.filter.contour_filter import TrackerParameters

__all__ = ['HEAD_SEQUENCES', 'acceptance_rows']

HEAD_SEQUENCES = ('david', 'david_colour', 'trellis', 'sunshade', 'seated_agbani', 'interview_alberto')


def acceptance_rows(results: dict[str, object]) -> list[dict[str, object]]:
    """The issues' bars against this run's figures: speed at 640x480, precision per sequence,
    confident-wrong frames, the start without a box, skin labels on HGR."""
    checks: list[dict[str, object]] = []

    def check(name: str, measured: float, bar: float | tuple[float, float], at_most: bool = False) -> None:
        if isinstance(bar, tuple):
            met = bar[0] <= measured <= bar[1]
        else:
            met = measured <= bar if at_most else measured >= bar
        checks.append({'check': name, 'measured': measured, 'bar': bar, 'met': met})

    speed = results.get('speed')
    if isinstance(speed, dict):
        stages, trackers = speed['stages_ms']['640x480'], speed['trackers_ms_640x480']
        check('particle filter step, 500 particles (ms) <= 1', stages['particle_filter_500'], 1.0, at_most=True)
        if 'CSRT' in trackers:
            check('head pipeline (ms) <= CSRT / 5', stages['pipeline'], round(trackers['CSRT'] / 5, 3), at_most=True)
            check('hand pipeline (ms) <= 3 KCF', stages['hand_pipeline'], round(3 * trackers['KCF'], 3), at_most=True)
            cpu = speed['trackers_cpu_ms_640x480']
            name = 'head pipeline, CPU of every thread (ms) <= CSRT / 5'
            check(name, stages['pipeline_cpu'], round(cpu['CSRT'] / 5, 3), at_most=True)
            name = 'hand pipeline, CPU of every thread (ms) <= 3 KCF'
            check(name, stages['hand_pipeline_cpu'], round(3 * cpu['KCF'], 3), at_most=True)
            # Issue 75: cheaper than KCF, OpenCV's cheapest box tracker people use.
            check('head pipeline (ms) <= KCF', stages['pipeline'], trackers['KCF'], at_most=True)
            name = 'head pipeline, CPU of every thread (ms) <= KCF'
            check(name, stages['pipeline_cpu'], cpu['KCF'], at_most=True)
            check(
                'hand pipeline (ms) <= 1.5 KCF', stages['hand_pipeline'], round(1.5 * trackers['KCF'], 3), at_most=True
            )
            if 'person_pipeline' in stages:
                # Two hands: a harder bar than the head and one hand.
                name = 'person pipeline, head and two hands (ms) <= 2 KCF'
                check(name, stages['person_pipeline'], round(2 * trackers['KCF'], 3), at_most=True)
        if 'person_pipeline' in stages:
            name = 'person pipeline, head and two hands (ms) <= 2.5 head pipeline'
            check(name, stages['person_pipeline'], round(2.5 * stages['pipeline'], 3), at_most=True)
    scores: dict[str, dict[str, float]] = {}
    wrong: dict[str, float] = {}
    falsely_lost: dict[str, float] = {}
    reported: dict[str, float] = {}  # a real head's annotated frames with a box, worst run
    consistency: dict[str, float] = {}  # the head bags' NEES
    held: dict[str, float] = {}  # a person's head beside a hand: the share under one id, worst run
    hand_ids: dict[str, tuple[float, int]] = {}  # a person's hand: IDF1 (mean), switches (most)
    for row in results.get('accuracy', []):  # type: ignore[union-attr]
        tracker, sequence = str(row['tracker']), str(row['sequence'])
        kind = tracker.split(' (')[0]
        name = f'{kind}, no box' if kind in ('ours', 'person') and 'no box' in tracker else kind
        # Mean over the runs: one seed of ours, or one draw of MIL, is luck on a hard sequence.
        scores.setdefault(sequence, {})[name] = float(row.get('precision_20px_mean', row['precision_20px']))
        if name.startswith(('ours', 'person')):
            # The worst run: a robot is told where a person is, wrongly, whichever seed it drew.
            wrong[f'{sequence} ({name})'] = float(row.get('confident_wrong_max', row.get('confident_wrong', 0.0)))
            if 'falsely_lost_max' in row:
                falsely_lost[f'{sequence} ({name})'] = float(row['falsely_lost_max'])
            if name.startswith('ours') and 'box_reported_min' in row:
                reported[f'{sequence} ({name})'] = float(row['box_reported_min'])
        if 'head_one_id_min' in row:
            held[f'{sequence} ({name})'] = float(row['head_one_id_min'])
        if 'head_one_id_min' in row and 'id_switches_max' in row:
            hand_ids[f'{sequence} ({name})'] = (float(row['idf1_mean']), int(row['id_switches_max']))
        if name == 'ours' and sequence.startswith('head_') and 'nees_mean' in row:
            consistency[sequence] = float(row['nees_mean'])
    for sequence, by in scores.items():
        rivals = [by[name] for name in ('CamShift', 'MIL', 'KCF') if name in by]
        check(f'{sequence}: mean precision at 20 px >= CamShift, MIL, KCF', by['ours'], max(rivals, default=0.0))
        if 'ours, no box' in by and sequence in HEAD_SEQUENCES:
            check(f'{sequence}: without a box >= 0.8 of with one', by['ours, no box'], round(0.8 * by['ours'], 3))
    at_csrt = [s for s in HEAD_SEQUENCES if s in scores and scores[s]['ours'] >= scores[s].get('CSRT', 1.0)]
    if any(s in scores for s in HEAD_SEQUENCES):
        check('head sequences where ours >= CSRT (of 6)', len(at_csrt), 4)
    # Issue 73, on every real head sequence (those run without a box too): CSRT's precision
    # from the first box, 0.9 of it without one; from the box and without, a box on at least
    # 0.95 of the annotated frames (the head stays in view on them) in the worst run.
    for sequence, by in scores.items():
        if 'ours, no box' not in by or 'hand' in sequence:
            continue
        if 'CSRT' in by:
            check(f'{sequence}: from the first box >= CSRT', by['ours'], by['CSRT'])
            check(f'{sequence}: without a box >= 0.9 CSRT', by['ours, no box'], round(0.9 * by['CSRT'], 3))
        for key in (f'{sequence} (ours)', f'{sequence} (ours, no box)'):
            if key in reported:
                check(f'{key}: annotated frames with a reported box, worst run >= 0.95', reported[key], 0.95)
    if 'hand2' in scores:
        check('hand2: mean precision at 20 px >= 0.6', scores['hand2']['ours'], 0.6)
        check('hand2: mean precision at 20 px >= CSRT', scores['hand2']['ours'], scores['hand2'].get('CSRT', 0.0))
        check('hand2: mean precision at 20 px >= 0.65', scores['hand2']['ours'], 0.65)
        if 'ours, no box' in scores['hand2']:
            check('hand2: from the box >= without one', scores['hand2']['ours'], scores['hand2']['ours, no box'])
    for name, share in wrong.items():
        check(f'{name}: confident-wrong share, worst run <= 0.05', share, 0.05, at_most=True)
    for name, share in falsely_lost.items():
        check(f'{name}: falsely lost share, worst run <= 0.05', share, 0.05, at_most=True)
    for name, share in held.items():
        check(f'{name}: the head keeps one id, share of frames, worst run >= 0.9', share, 0.9)
    for name, (idf1, switches) in hand_ids.items():
        check(f"{name}: the hand's IDF1, mean >= 0.8", idf1, 0.8)
        check(f'{name}: identity switches of the hand, worst run <= 1', switches, 1, at_most=True)
    for sequence, nees in consistency.items():
        check(f'{sequence}: pose NEES of x, y within a factor 2 of 2', nees, (1.0, 4.0))
    people: list[dict[str, object]] = results.get('people', [])  # type: ignore[assignment]
    if people:
        tracks = [name for name in people[0] if '/' in name]
        # The bar is the bag's replay, at the seed `track` and the nodes run by default; the
        # other seeds, beyond it, say how often another draw of the particles misses it.
        for row in (row for row in people if row['seed'] == TrackerParameters().seed):
            runs = f"people_crossing, two people, the replay's seed ({row['seed']})"
            worst = min(float(row[name]) for name in tracks)  # type: ignore[arg-type]
            check(f"{runs}: every track's precision at 20 px >= 0.9", worst, 0.9)
            check(f'{runs}: identity switches <= 0', row['id_switches'], 0, at_most=True)
            check(f'{runs}: IDF1 >= 0.9', row['idf1'], 0.9)
        runs = f'people_crossing, two people, {len(people)} seeds (beyond the bar)'
        worst = min(float(row[name]) for row in people for name in tracks)  # type: ignore[arg-type]
        check(f"{runs}: every track's precision at 20 px, worst seed >= 0.9", worst, 0.9)
        switched = sum(int(row['id_switches']) > 0 for row in people)  # type: ignore[call-overload]
        check(f'{runs}: seeds with an identity switch <= 0', switched, 0, at_most=True)
        check(f'{runs}: IDF1, worst seed >= 0.9', min(float(row['idf1']) for row in people), 0.9)  # type: ignore[arg-type]
    for row in results.get('real_people', []):  # type: ignore[union-attr]
        check(f'two real people side by side, seed {row["seed"]}: IDF1 >= 0.9', row['idf1'], 0.9)
    for row in results.get('latency', []):  # type: ignore[union-attr]
        if row['rate'] == 'full speed':
            continue
        layout = f'latency, {row["layout"]}, {row["rate"]}'
        if row.get('busy_processes'):
            layout += f', {row["busy_processes"]} busy processes'
        check(f'{layout}: poses received of {row["frames_sent"]} sent', row['poses_received'], row['frames_sent'])
        if row.get('busy_processes'):
            # Issue 75: beside busy processes, a frame waits at most 2 ms beyond its processing.
            check(f'{layout}: median above processing (ms) <= 2', row['above_processing_ms'], 2.0, at_most=True)
            check(f'{layout}: p95 (ms) < 33', row['latency_ms_p95'], 33.0, at_most=True)
        elif row['layout'] == 'separate':
            check(f'{layout}: median (ms) <= 5', row['latency_ms_median'], 5.0, at_most=True)
            check(f'{layout}: p95 (ms) <= 10', row['latency_ms_p95'], 10.0, at_most=True)
        else:
            check(f'{layout}: median above processing (ms) <= 1', row['above_processing_ms'], 1.0, at_most=True)
    for row in results.get('skin', []):  # type: ignore[union-attr]
        if 'f1' in row:
            name = f'{row["sequence"]}, {row["method"]}'
            check(f'{name}: skin F1 >= 0.92', float(row['f1']), 0.92)
            check(f'{name}: skin recall >= 0.9', float(row['recall']), 0.9)
    return checks
