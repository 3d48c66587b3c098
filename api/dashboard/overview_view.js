// The overview: one card per controller (overview.js), in id order, live from the store.

import { store } from "./store.js";
import { ControllerCard } from "./overview.js";
import { el } from "./dom.js";

export function mount(container) {
  const grid = el("div", { class: "cards", id: "cards" });
  container.append(grid);
  const cards = new Map();

  const cardOf = (id) => {
    let c = cards.get(id);
    if (!c) {
      c = new ControllerCard(id);
      cards.set(id, c);
      const ids = [...cards.keys()].sort();
      const next = cards.get(ids[ids.indexOf(id) + 1]);
      grid.insertBefore(c.root, next ? next.root : null);
    }
    return c;
  };
  const render = ({ id, controller, what }) => {
    const c = cardOf(id);
    if (what === "gap") c.gap();
    else if (what === "state") c.setState(controller.state);
    else if (controller.position) c.setPositions(controller.position.axes, controller.position.busy);
  };
  for (const [id, controller] of store.controllers) {
    if (controller.state) render({ id, controller, what: "state" });
  }
  const showLease = ({ id, lease, error }) => cardOf(id).setLease(lease, error);
  for (const [id, entry] of store.leases) showLease({ id, ...entry });
  const stops = [store.on("controller", render), store.on("lease", showLease)];
  return () => {
    for (const stop of stops) stop();
    for (const c of cards.values()) c.destroy?.();
  };
}
