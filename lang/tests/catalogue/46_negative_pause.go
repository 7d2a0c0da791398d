// PauseFor waits a duration of 0 seconds or more.
package NegativePause

const Wait = 3

var D1 Quadcopter

func INIT() {
	D1.Takeoff(1)
	PauseFor(1 - Wait)
	D1.Land()
}
