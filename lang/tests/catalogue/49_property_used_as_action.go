// A property read as a statement does nothing: it is not an action.
package PropertyStatement

var D1 Quadcopter

func INIT() {
	D1.Takeoff(1)
	D1.Battery()
}
