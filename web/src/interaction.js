// The page's pointer work (web/src/page.js gives it the view and the editing functions as `ctx`):
//   click on the surface          a point handle at the clicked point (its rest: the same point of the rest mesh;
//                                 on a splat scene: at the splat centre nearest the ray, by its index)
//   shift-drag on the surface     a segment handle from where the drag starts to where it ends
//   click on a handle             select it (the gizmo moves it); ctrl-click adds it to (or takes it from) a group
//   a group of two or more        the gizmo rotates (R) or moves (T) them as one rigid body about their centroid
import * as THREE from 'three';

export function installInteraction(ctx) {
  const { state, scene, camera, renderer, gizmo, orbit } = ctx;
  const raycaster = new THREE.Raycaster();
  const pivot = new THREE.Object3D();
  scene.add(pivot);
  let down = null, groupStart = null;

  const cast = (e) => {
    // The camera and the markers as they are now, not as the last rendered frame left them: a click may come
    // before the first frame after a mesh is opened (the rays then started at the origin and missed).
    scene.updateMatrixWorld();
    camera.updateMatrixWorld();
    const rect = renderer.domElement.getBoundingClientRect();
    raycaster.setFromCamera(new THREE.Vector2(((e.clientX - rect.left) / rect.width) * 2 - 1,
      -((e.clientY - rect.top) / rect.height) * 2 + 1), camera);
  };
  // A splat scene is hit at a splat's centre ({point, splat}: page_splats.js), a mesh on its surface.
  const surface = (e) => {
    cast(e);
    if (state.splats) return ctx.pickSplat(raycaster);
    return raycaster.intersectObject(state.object)[0] ?? null;
  };
  /** The rest-mesh point with the hit's barycentric coordinates in its triangle (a splat's: its rest centre). */
  const restPoint = (hit) => {
    if (hit.splat !== undefined) return Array.from(state.mesh.vertices.subarray(3 * hit.splat, 3 * hit.splat + 3));
    const tri = state.mesh.triangles, rest = state.mesh.vertices, now = state.object.geometry.attributes.position.array;
    const corner = (a, i) => new THREE.Vector3().fromArray(a, 3 * tri[3 * hit.faceIndex + i]);
    const b = new THREE.Triangle(corner(now, 0), corner(now, 1), corner(now, 2)).getBarycoord(hit.point, new THREE.Vector3());
    return corner(rest, 0).multiplyScalar(b.x).add(corner(rest, 1).multiplyScalar(b.y)).add(corner(rest, 2).multiplyScalar(b.z))
      .toArray().map(Math.fround);
  };
  const at = (hit) => hit.point.toArray().map(Math.fround);

  /** Adds a handle (the rest pose changes: a new session); undone if the library refuses it. */
  function addHandle(add) {
    ctx.pushUndo();
    add();
    try {
      ctx.rebuild();
      ctx.showError(null);
      return true;
    } catch (e) {
      ctx.undoLast();
      ctx.showError(e);
      return false;
    }
  }

  function setGroup(members) {
    state.group = members;
    state.selected = -1;
    if (members.length < 2) {
      gizmo.detach();
      if (members.length === 1) ctx.select(members[0]);
      else ctx.select(-1);
      state.group = [];
      return;
    }
    const c = new THREE.Vector3();
    for (const i of members) c.add(new THREE.Vector3().fromArray(state.handles.points[i].target));
    pivot.position.copy(c.divideScalar(members.length));
    pivot.quaternion.identity();
    gizmo.setMode('rotate');
    gizmo.attach(pivot);
    ctx.placeMarkers();
  }

  gizmo.addEventListener('dragging-changed', (e) => {
    if (!e.value || gizmo.object !== pivot) return;
    groupStart = {
      position: pivot.position.clone(),
      inverse: pivot.quaternion.clone().invert(),
      targets: state.group.map((i) => new THREE.Vector3().fromArray(state.handles.points[i].target)),
    };
  });
  gizmo.addEventListener('objectChange', () => {
    if (gizmo.object !== pivot || !groupStart) return;
    // x -> R (x - c0) + c, R the gizmo's rotation since the drag began, c its position.
    const R = pivot.quaternion.clone().multiply(groupStart.inverse);
    state.group.forEach((i, k) => {
      const x = groupStart.targets[k].clone().sub(groupStart.position).applyQuaternion(R).add(pivot.position);
      state.handles.points[i].target = x.toArray().map(Math.fround);
    });
    try {
      ctx.deform();
      ctx.showError(null);
    } catch (e) {
      ctx.showError(e);
    }
  });
  window.addEventListener('keydown', (e) => {
    if (gizmo.object !== pivot) return;
    if (e.key === 'r') gizmo.setMode('rotate');
    if (e.key === 't') gizmo.setMode('translate');
  });

  renderer.domElement.addEventListener('pointerdown', (e) => {
    down = { x: e.clientX, y: e.clientY, shift: e.shiftKey, hit: e.shiftKey ? surface(e) : null };
    if (down.hit) orbit.enabled = false;  // the shift-drag draws a segment instead of orbiting
  });
  renderer.domElement.addEventListener('pointerup', (e) => {
    const start = down;
    down = null;
    if (!start || gizmo.dragging) return;
    if (start.hit) {
      orbit.enabled = true;
      const end = surface(e);
      if (!end || Math.hypot(e.clientX - start.x, e.clientY - start.y) <= 4) return;
      const ends = start.hit.splat !== undefined ? [start.hit.splat, end.splat] : null;
      addHandle(() => state.handles.segments.push({ restA: restPoint(start.hit), restB: restPoint(end), targetA: at(start.hit),
        targetB: at(end), vertices: ends, name: '' }));
      return;
    }
    if (Math.hypot(e.clientX - start.x, e.clientY - start.y) > 4 || gizmo.axis) return;
    cast(e);
    const onMarker = raycaster.intersectObjects(state.markers.filter((m) => m.userData.handle !== undefined))[0];
    if (onMarker) {
      const i = onMarker.object.userData.handle;
      if (!(e.ctrlKey || e.metaKey)) return setGroup([i]);
      const members = state.group.length ? [...state.group] : state.selected >= 0 ? [state.selected] : [];
      return setGroup(members.includes(i) ? members.filter((j) => j !== i) : [...members, i]);
    }
    const hit = surface(e);
    if (!hit) return setGroup([]);
    state.group = [];
    gizmo.setMode('translate');
    if (addHandle(() => state.handles.points.push({ rest: restPoint(hit), target: at(hit), vertex: hit.splat ?? -1, name: '' })))
      ctx.select(state.handles.points.length - 1);
  });

  return { setGroup };
}
