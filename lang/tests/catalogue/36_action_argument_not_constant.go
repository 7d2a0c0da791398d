// Action arguments are known before the flight; a property is not.
package NotConstant

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	D1.FlyByX(D2.X() - D1.X())
	D2.Takeoff(D1.IsArmed())
}
